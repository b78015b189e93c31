"""A mission that drives a planned path: plan, drive, watch, recover, arrive (§2.7, §2.4).

The planned polyline is shaped into clothoid turns the board can drive without a jump in
its gear ratio (motion/shaping.py), given a jerk-limited speed profile and streamed to
the board tick by tick, steering back onto the path from the pose estimate
(motion/executor.py). `go <room>` and a taught route followed closed-loop are both this;
they differ in where the path comes from (`_course`).

The mission is a small state machine (issue 25, item 4): at every moment it is in one
`Stage`, and every change of stage is named, as Nav2's behaviour trees name their
recoveries.

- DRIVING: the executor drives the plan. The range finder's obstacles go into the grid
  and the D* Lite planner of the leg under way replans incrementally (§2.6.4;
  lookout.py). At the plan's end, arrival.py says whether it has arrived.
- STOPPING: a jerk-limited stop along the path, then what comes next: a new plan round
  something in the way or a door shut on the route, a look for a marker, or the end.
- HALTING: a stop at once, after a contact (a stall: §2.3.2); then BACKING_OFF.
- BACKING_OFF: straight back the way it came, then, with markers, a look until one has
  fixed the pose again, and a new plan (recovery.py says why in that order).
- LOOKING: turning on the spot to find a marker (localising.py): before setting off from
  a pose no marker has confirmed, when lost, and before claiming an arrival.
- TURNING: at the goal, on the spot to the room's heading.
- ENDED: with an `Outcome` (robot/mission.py) and its words.

Knowing where it is (issue 14, 25): with an `estimate` that has markers to go by, the
mission minds how well the robot knows where it is, by the bounds of certainty.py. It
never sets off from a pose that only an assumption vouches for (a restarted daemon's,
a console's first): with markers it looks first, without any it does not start. Unsure,
it drives slower; lost, it stops, looks, and plans again from where the marker says it
is; and it claims ARRIVED only on a fresh marker fix within the arrival bounds, else
ARRIVED_UNVERIFIED, with the metres driven on the odometry alone (arrival.py). Its turns on the spot
are steered as steady_turn.py says.

A mission that fails brings the robot to rest first and then reports its problem, so
that a patrol can carry on to its next stop; the control loop stops the robot besides.

What `progress` gives is the plan under way: while the robot stops to plan again it
says so rather than giving the few centimetres of braking left, and when the robot
gets no nearer it says for how long rather than an ETA.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from giraff_console.camera.marker_reach import STANDARD_SIZE_M
from giraff_console.link.motor_state import MotorState
from giraff_console.missions.arrival import Arrival, Verdict, by_odometry
from giraff_console.missions.certainty import (
    SLOW_FRACTION,
    confirmed,
    found_again,
    how_lost,
    lost,
    lost_again,
    moved,
    settling,
    slow_stretches,
    sure,
    trusted,
    unverified,
)
from giraff_console.missions.localising import Look
from giraff_console.missions.localising import Outcome as LookOutcome
from giraff_console.missions.lookout import Lookout, Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.progress_watch import Patience, ProgressWatch
from giraff_console.missions.recovery import FELT_EXTENT_M, MAX_CONTACTS, Recovery
from giraff_console.missions.steady_turn import SteadyTurn
from giraff_console.motion.executor import Executor, Trace
from giraff_console.motion.path import Drive, Reverse, Rotation, Section, wrap
from giraff_console.motion.shaping import TurnLimits, shape
from giraff_console.motion.speed_profile import MotionLimits, SlowZone
from giraff_console.planning.landmarks import marker_poses
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import PlannedPath
from giraff_console.protocol.codec import Command
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import ARRIVED, DRIVING, PAUSED, Outcome, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import stop_commands

Point = tuple[float, float]


# A doorway is passed slowly this far either side of its centre.
DOOR_ZONE_M = 0.4
# After this long without progress, the progress line says so instead of an ETA.
SHOW_STILL_S = 5.0
# Sensed obstacles this close to the robot are what a stuck mission names as the cause.
CAUSE_NEAR_M = 1.5
# Halting after a contact, the stop is sent again this often while the board still
# says it moves: once is enough on a board that answers, and never a flood.
HALT_EVERY_S = 0.5
# A stop along the path takes at most a few seconds (a full turn on the spot finishing
# first, at the limits); one still going after this long is held by wheels that do not
# turn, and is stopped at once instead.
STOP_WAIT_S = 10.0
# A board whose stop has not run out after this long is pushing its wheels against what
# they touch (the move's ramp waits on wheels that do not turn: 0.4 m/s at 0.5 m/s^2
# ramps down in 0.8 s): the recovery goes on, and its move back replaces the stop.
HALT_WAIT_S = 1.0


class Stage(enum.Enum):
    """What a path mission is doing (module docstring)."""

    DRIVING = "driving"
    STOPPING = "stopping"
    HALTING = "stopping at once"
    BACKING_OFF = "backing off"
    LOOKING = "looking for a marker"
    TURNING = "turning to the room's heading"
    ENDED = "ended"


class LookFor(enum.Enum):
    """Why a mission looks for a marker, and so when it has seen enough."""

    LOST = "lost"  # known too loosely to drive on: until it is sure again
    CONTACT = "contact"  # touched something: until a marker has fixed the pose since
    ARRIVAL = "arrival"  # at the goal: until the estimate is within the arrival bounds


# The stages the progress watch's time limit ends: a look for a marker and a recovery
# from a contact have bounds of their own, and a stop that is already ending the
# mission is let finish.
WATCHED = frozenset({Stage.DRIVING, Stage.TURNING, Stage.STOPPING})
# Those bounds, in seconds of the stage, and how a mission that overstays one ends: a
# look's sweep is six turns of 60 degrees with a pause and a gather at each, and a few
# turns to the best markers seen, under a minute; backing off is BACK_OFF_M at a creep,
# a few seconds. A turn that hunts round its end, or a reverse that never gets there,
# is ended here rather than left to run.
STAGE_LIMITS = {Stage.LOOKING: (120.0, Outcome.LOST), Stage.BACKING_OFF: (30.0, Outcome.STALLED)}


@dataclass(frozen=True)
class Course:
    """Where a path mission drives from a pose: the polyline and what it passes."""

    points: list[Point]
    goal_heading: float | None = None  # radians; None: whatever the path ends with
    doorways: frozenset[Point] = frozenset()  # crossed straight (shaping's pins)
    doors: tuple[str, ...] = ()  # the doors passed, by id
    planned: PlannedPath | None = None  # the room graph's route, for D* Lite replanning


@dataclass(frozen=True)
class Tick:
    """What one step of the mission goes by: the time, the board's state, the pose it
    steers by, and the estimate while it minds one (None: by the odometry alone)."""

    now: float
    state: MotorState
    pose: Pose
    estimate: Estimate | None


# What a stop leads to, once the robot is still.
Then = Callable[[Tick], list[Command]]


class PathMission:
    """A Mission that drives the course `_course` gives; see the module docstring.

    Planning happens when the mission is made (PlanningError if there is no way), so
    the console makes it off its UI thread.
    """

    name: str
    retry: str  # what the operator types to try again
    # Set by _plan, which __init__ calls.
    _sections: tuple[Section, ...]
    _closed: frozenset[str]
    _crossings: frozenset[Point]

    def __init__(
        self,
        navigator: Navigator | None,
        pose: Callable[[], Pose],
        *,
        tick: float,
        limits: MotionLimits | None = None,
        turn_limits: TurnLimits | None = None,
        sense: Sense | None = None,
        notify: Callable[[str], None] = lambda text: None,
        patience: Patience | None = None,
        estimate: Callable[[], Estimate] | None = None,
        touched: Callable[[], None] = lambda: None,
        markers: Callable[[], Mapping[int, Pose]] | None = None,
    ) -> None:
        """`notify` gets a line for the operator when the mission changes its plan;
        `patience` says how long it may go without getting nearer before it gives up.
        `estimate`, called on the control loop's thread when the mission is stepped,
        says how well `pose` is known (see the module docstring); without it, the
        mission steers by `pose` alone. `touched` tells whoever keeps the estimate that
        the robot has touched something (localisation.touched); `markers` gives the
        markers a look turns to, those it knows well enough to find the robot by now
        (localisation.markers: a survey's, as it learns them); without it, the plan's."""
        self.navigator = navigator
        self.notify = notify
        self.limits = limits or MotionLimits()
        self.turn_limits = turn_limits or TurnLimits()
        self.tick = tick
        self._pose = pose
        self._lookout = Lookout(navigator, sense) if navigator and sense else None
        self.problem: str | None = None
        # How it ended, once it has (robot/mission.py), and the words for it.
        self.outcome: Outcome | None = None
        self.detail = ""
        self.replans = 0
        self._started: float | None = None
        self._ended: float | None = None
        self._now = 0.0
        self._paused = False
        self._stage = Stage.DRIVING
        self._timed: tuple[Stage, float] | None = None  # the stage under way, and since
        self._stopping_why = ""  # what a STOPPING stage says it stops for
        self._then: Then = lambda tick: []  # what STOPPING, HALTING, BACKING_OFF lead to
        self._halted_at: float | None = None  # the last stop sent while halting
        self._halt_began: float | None = None
        self._stopping_since: float | None = None
        self._failing = False  # coming to rest to end (`_fail`)
        # The traces of the plans driven before the present one (after replanning).
        self._traces: list[Trace] = []
        self._estimate = estimate
        self._touched = touched
        if markers is None:
            planned = marker_poses(navigator.plan, known_only=True) if navigator else {}
            markers = lambda: planned  # noqa: E731
        self._markers = markers
        landmarks = navigator.plan.landmarks if navigator else None
        self._marker_size = landmarks.size if landmarks else STANDARD_SIZE_M
        self._look: Look | None = None
        self._look_for = LookFor.LOST
        self._begun = False  # the first step has judged whether it may set off
        self._set_off = False  # the robot has been commanded to move
        # With markers to find the robot by, plans are slowed where it will be unsure:
        # from their start when made unsure, and after turns on the spot (`turned`: it
        # has just turned before the plan starts).
        self._minding = False
        self._unsure_start = False
        self._turned = False
        self._arrival = Arrival()
        self._steady_turn = SteadyTurn()
        self._recovery = Recovery(navigator.planner.robot_radius if navigator else 0.3)
        self._felt: list[Point] = []  # contacts it put on the grid (recovery.py)
        self._goal: tuple[Point, float | None] = ((0.0, 0.0), None)
        # Planned from where the robot is assumed to be: a first look may move it.
        self.executor = self._plan(pose())
        self.time_optimal = self.executor.time_optimal
        self._progress_watch = ProgressWatch(patience or Patience(), 0.0, self.executor.remaining())

    def _course(self, pose: Pose) -> Course:
        """The way to go from `pose`; PlanningError if there is none."""
        raise NotImplementedError

    def _arrived_already(self, pose: Pose) -> bool:
        """Whether a robot at `pose`, found there by a first look, need not move at all."""
        return False

    @property
    def stage(self) -> Stage:
        return self._stage

    @property
    def contacts(self) -> int:
        """How many times the robot touched something on the way."""
        return len(self._recovery.contacts)

    def since_fix_m(self) -> float | None:
        """Metres driven on the odometry alone since the pose was last fixed (a marker,
        or the placing); None without an estimate."""
        raw = self._estimate() if self._estimate is not None else None
        return None if raw is None else raw.since_fix_m

    @property
    def replanning(self) -> bool:
        """Whether the plan being made is a new way (after setting off), not the first."""
        return self._set_off or self.replans > 0

    # -- the Mission protocol -----------------------------------------------------------

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        self._now = now
        if self._started is None:
            self._started = now
            self._progress_watch.restart(now)
        if self._paused or state is None or self._stage is Stage.ENDED:
            return []
        pose = self._pose()
        raw = self._estimate() if self._estimate is not None else None
        if not self._begun:
            self._begun = True
            refusal = unverified(raw, self.retry)
            if refusal is not None:
                self._end(Outcome.UNVERIFIED, f"not started: {refusal}")
                return []
        # No markers to find the robot by: the odometry is all there is.
        estimate = raw if raw is not None and raw.landmarks else None
        self._mind_the_estimate(estimate)
        tick = Tick(now, state, pose, estimate)
        if self._lookout is not None:
            self._watch(tick)
        if self._stage is Stage.DRIVING:
            self._interrupt(tick)
        if self._progress_watch.stuck(now) and self._stage in WATCHED:
            how = f"stuck for {self._progress_watch.still_for(now):.0f} s near {{}}"
            return self._fail(tick, Outcome.BLOCKED, self._stuck(pose, how))
        overstayed = self._overstayed(now)
        if overstayed is not None:
            return self._fail(tick, *overstayed)
        commands = self._steps[self._stage](self, tick)
        self._recovery.trail(pose)
        return commands

    def _overstayed(self, now: float) -> tuple[Outcome, str] | None:
        """How the mission ends if its stage has run past its limit (STAGE_LIMITS)."""
        if self._timed is None or self._timed[0] is not self._stage:
            self._timed = (self._stage, now)
        limit = STAGE_LIMITS.get(self._stage)
        if limit is None or now - self._timed[1] <= limit[0] or self._failing:
            return None
        return limit[1], (f"{self._stage.value} took over {limit[0]:.0f} s; drive the robot "
                          f"by hand, then type {self.retry} again")  # fmt: skip

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        """The loop stops the robot; on resuming, the rest is planned from where it is."""
        self._paused = True

    def resume(self, now: float) -> None:
        if not self._paused:
            return
        self._paused = False
        if self._stage is Stage.ENDED:
            return
        self._drop_look()  # a look, if it still must, starts again from the stop
        self.executor.abandon()
        self._arrival.anew()  # it may have been driven anywhere by hand meanwhile
        self._progress_watch.restart(now)
        self._stop_then(now, "resuming", self._plan_again)

    @property
    def finished(self) -> bool:
        """Arrived, confirmed or not; a mission that failed has a `problem` instead."""
        return self.outcome is not None and self.outcome.arrived

    @property
    def started_at(self) -> float | None:
        """When it was first stepped."""
        return self._started

    @property
    def ended_at(self) -> float | None:
        """When it arrived, if it has."""
        return self._ended

    @property
    def now(self) -> float:
        """The time of its last step."""
        return self._now

    def pose_now(self) -> Pose:
        """Where the robot is, as the mission steers by it."""
        return self._pose()

    @property
    def progress(self) -> Progress:
        """The plan under way: the metres left of it and the time left, for the main view."""
        if self.finished:
            return Progress(self.name, ARRIVED)
        if self._stage is Stage.LOOKING and self._look is not None:
            return Progress(self.name, self._look.state, total_m=self._total)
        if self._stage is Stage.STOPPING:
            # The plan being given up says nothing true of the way left: the braking
            # metres of the old one would read as nearly there.
            why = f"stopping to plan a new way ({self._stopping_why})"
            return Progress(self.name, why, total_m=self._total)
        if self._stage in (Stage.HALTING, Stage.BACKING_OFF):
            tries = f"contact {self._recovery.in_a_row}"
            return Progress(self.name, f"touched something: {self._stage.value} ({tries})",
                            total_m=self._total)  # fmt: skip
        left = self.executor.remaining()
        if self._paused:
            return Progress(self.name, PAUSED, left, self._total)
        still = self._progress_watch.still_for(self._now)
        if self.problem is None and still >= SHOW_STILL_S:
            return Progress(self.name, f"no nearer for {still:.0f} s", left, self._total)
        # The profile's time left, but never less than the distance at full speed: a
        # robot behind its profile would otherwise show 0:00 with metres still to go.
        eta = max(self.executor.remaining_time(self._now), left / self.limits.v_max)
        return Progress(self.name, DRIVING, left, self._total, eta)

    def merged_trace(self) -> Trace:
        """What was commanded over every plan driven, one trace."""
        trace = Trace([], [])
        for each in [*self._traces, self.executor.trace]:
            trace.starts += [len(trace.times) + start for start in each.starts]
            trace.times += each.times
            trace.speeds += each.speeds
            trace.stops += each.stops
            trace.gear_jumps += each.gear_jumps
        return trace

    # -- the stages ---------------------------------------------------------------------

    def _driving(self, tick: Tick) -> list[Command]:
        """The plan under way; at its end, the arrival (`_arrive`)."""
        steer = tick.pose
        casters = 0.0
        if tick.estimate is not None:
            steer = self._steady_turn.pose(self.executor, tick.pose, tick.estimate.odometry)
            casters = tick.estimate.caster_rate
        commands = self.executor.step(tick.now, tick.state, steer, casters)
        self._set_off = self._set_off or bool(commands)
        executor = self.executor
        if executor.stalled:
            return [*commands, *self._contact(tick)]
        if executor.problem is not None:
            self._end(Outcome.FAILED, executor.problem)
            return commands
        if executor.finished:
            return [*commands, *self._arrive(tick)]
        left = executor.remaining()
        self._progress_watch.driven(tick.now, left)
        self._recovery.driven(left)
        return commands

    def _stopping(self, tick: Tick) -> list[Command]:
        """A jerk-limited stop along the path; once the robot is still, what is next."""
        if self._stopping_since is None:
            self._stopping_since = tick.now
        commands = self.executor.step(tick.now, tick.state, tick.pose)
        overdue = tick.now - self._stopping_since > STOP_WAIT_S
        if self.executor.stalled or overdue:
            # Touching something while braking, or a stop that does not run out: the
            # board holds a move its wheels cannot finish. Stopped at once.
            self._stage, self._stopping_since = Stage.HALTING, None
            return self._halting(tick)
        done = self.executor.finished or self.executor.problem is not None
        if not done or tick.state.moving:
            return commands
        self._stopping_since = None
        return [*commands, *self._then(tick)]

    def _halting(self, tick: Tick) -> list[Command]:
        """Stop at once (the board still holds a move that pushes); once still, or once
        HALT_WAIT_S have shown that its stop cannot run out against what the robot
        touches, next: a move back replaces it."""
        if self._halt_began is None:
            self._halt_began = tick.now
        if not tick.state.moving or tick.now - self._halt_began >= HALT_WAIT_S:
            self._halt_began = self._halted_at = None
            return self._then(tick)
        if self._halted_at is not None and tick.now - self._halted_at < HALT_EVERY_S:
            return []
        self._halted_at = tick.now
        style = self.executor.style
        return stop_commands(tick.state, float(style if style is not None else 1))

    def _looking(self, tick: Tick) -> list[Command]:
        look = self._look
        assert look is not None
        estimate = tick.estimate
        if estimate is None:
            self._drop_look()  # the markers were taken away: plan again, by the odometry
            return self._plan_again(tick)
        commands = look.step(tick.now, tick.state, estimate)
        if look.problem is not None:
            self._end(Outcome.FAILED, look.problem)
            return []
        if not look.finished:
            return commands
        self._drop_look()
        if look.outcome is LookOutcome.NOT_FOUND and estimate.lost:
            self._end(Outcome.LOST, lost(estimate, self.retry))
            return []
        if self._look_for is LookFor.ARRIVAL:
            if look.outcome is LookOutcome.NOT_FOUND:
                self.notify(f"{self.name}: no marker in sight to confirm the arrival "
                            f"(±{estimate.sigma_m:.2f} m)")  # fmt: skip
            self._arrival.looked(look.outcome is LookOutcome.FOUND)
            return [*commands, *self._arrive(tick)]
        if look.outcome is LookOutcome.NOT_FOUND:
            self.notify(f"{self.name}: no marker in sight, ±{estimate.sigma_m:.2f} m; "
                        "carrying on")  # fmt: skip
        else:
            seen = ", ".join(str(i) for i in estimate.seen) or "a marker"
            self.notify(f"{self.name}: found by {seen}, ±{estimate.sigma_m:.2f} m; carrying on")
        if not self._set_off and self._arrived_already(tick.pose):
            self._started = self._ended = tick.now
            self._end(Outcome.ARRIVED if trusted(estimate) else Outcome.ARRIVED_UNVERIFIED,
                      "there already")  # fmt: skip
            return commands
        if self._replan(tick.pose, estimate, turned=True):
            # Before setting off too: a robot that keeps finding markers too far to be sure
            # by must not turn on the spot for ever.
            self._progress_watch.looked(tick.now - (look.started_at or tick.now),
                                        self.executor.remaining())  # fmt: skip
        return commands

    def _backing_off(self, tick: Tick) -> list[Command]:
        commands = self.executor.step(tick.now, tick.state, tick.pose)
        if self.executor.stalled:
            # Touching behind as well: nothing here is safe to try.
            return self._fail(tick, Outcome.STALLED, self._stuck(
                tick.pose, "stalled: touched something ahead and behind near {}"))  # fmt: skip
        if self.executor.problem is not None:
            self._end(Outcome.FAILED, self.executor.problem)
            return commands
        if not self.executor.finished or tick.state.moving:
            return commands
        return [*commands, *self._then(tick)]

    def _ended_stage(self, tick: Tick) -> list[Command]:
        return []

    _steps: dict[Stage, Callable[[PathMission, Tick], list[Command]]] = {
        Stage.DRIVING: _driving,
        Stage.TURNING: _driving,
        Stage.STOPPING: _stopping,
        Stage.HALTING: _halting,
        Stage.BACKING_OFF: _backing_off,
        Stage.LOOKING: _looking,
        Stage.ENDED: _ended_stage,
    }

    # -- changes of stage ---------------------------------------------------------------

    def _stop_then(self, now: float, why: str, then: Then) -> None:
        """STOPPING: brake along the path (a turn on the spot finishes first), then `then`."""
        self.executor.brake(now)
        self._stage, self._stopping_why, self._then = Stage.STOPPING, why, then
        self._stopping_since = None

    def _fail(self, tick: Tick, outcome: Outcome, why: str) -> list[Command]:
        """Bring the robot to rest, then end with `outcome` (module docstring): at once
        against a stall, whose move the board holds, else along the path."""

        def end(tick: Tick) -> list[Command]:
            self._end(outcome, why)
            return []

        if self._failing:
            return self._steps[self._stage](self, tick)  # on its way to an end already
        self._failing = True
        if not tick.state.moving:
            return end(tick)
        if self.executor.stalled:
            self._stage, self._then = Stage.HALTING, end
            return self._halting(tick)
        self._stop_then(tick.now, why, end)
        return self._stopping(tick)

    def _forget_felt(self) -> None:
        """Take off the grid the contacts this mission put there."""
        if self._felt and self.navigator is not None:
            self.navigator.forget_obstacles(self._felt, margin=FELT_EXTENT_M)
        self._felt = []

    def _end(self, outcome: Outcome, why: str) -> None:
        self._stage = Stage.ENDED
        # What this mission only felt is its own belief: the next mission tries afresh,
        # and the range finder, where there is one, says what is really there. Not
        # after contacts ended it: a patrol's next stop, planned through the same
        # unseen thing, would push into it again; a new mission that then finds no way
        # forgets it (Navigator.go's `afresh`).
        if outcome is not Outcome.STALLED:
            self._forget_felt()
        self.outcome, self.detail = outcome, why
        if outcome.arrived:
            self._ended = self._now
        else:
            self.problem = why

    def _plan_again(self, tick: Tick, blocked: bool = False) -> list[Command]:
        """From a stop: a new way from here, unless too many came to nothing. `blocked`:
        the stop was for something in the way, which before the robot set off counts
        too (_replan's `again`)."""
        if self._progress_watch.out_of_replans():
            self._end(
                Outcome.BLOCKED,
                self._stuck(
                    tick.pose,
                    f"stuck near {{}} after "
                    f"{self._progress_watch.replans} new ways in a row that got no nearer",
                ),
            )
            return []
        first = not self._set_off
        if self._replan(tick.pose, tick.estimate, again=blocked) and not first:
            self._progress_watch.replanned(self.executor.remaining())
        return []

    def _look_now(self, tick: Tick) -> list[Command]:
        """From a stop, lost: look for a marker, unless looks keep coming to nothing."""
        estimate = tick.estimate
        if estimate is None:
            return self._plan_again(tick)
        if self._progress_watch.out_of_looks():
            self._end(Outcome.LOST, lost_again(tick.pose, self._progress_watch.looks, self.retry))
            return []
        self._start_look(estimate, None, LookFor.LOST)
        return self._looking(tick)

    def _start_look(self, estimate: Estimate, prefer: float | None, kind: LookFor) -> None:
        """LOOKING, until what `kind` looks for has been seen (LookFor)."""
        walls = self.navigator.sight_walls() if self.navigator is not None else []
        if kind is LookFor.ARRIVAL:
            why = f"arrived, known to ±{estimate.sigma_m:.2f} m: looking for a marker"
            enough = confirmed
        elif kind is LookFor.CONTACT:
            why = "touched something: looking for a marker to know where it is again"
            enough = found_again
        else:
            why = f"{how_lost(estimate)}: looking for a marker"
            enough = sure
        self._look_for = kind
        self._look = Look(estimate, self._markers(), walls, limits=self.limits, tick=self.tick,
                          enough=enough, prefer=prefer, why=why,
                          size=self._marker_size)  # fmt: skip
        self._stage = Stage.LOOKING

    def _drop_look(self) -> None:
        if self._look is not None:
            self._traces.extend(self._look.traces)
            self._look = None

    # -- contacts (recovery.py) ---------------------------------------------------------

    def _contact(self, tick: Tick) -> list[Command]:
        """A stall: stop at once, then back off, find the pose again and try again."""
        navigator = self.navigator
        doorways = [door.at for door in navigator.plan.doors] if navigator else []
        contact = self._recovery.touched(tick.pose, navigator.walls if navigator else None,
                                         doorways)  # fmt: skip
        self._touched()  # the estimate is less sure than the filter thinks
        where = f"({contact.point[0]:.1f}, {contact.point[1]:.1f})"
        if self._recovery.exhausted:
            why = self._stuck(tick.pose, f"stalled: touched something {self._recovery.touches}")
            return self._fail(tick, Outcome.STALLED, why)
        self.notify(
            f"{self.name}: touched something at {where}; backing off to try again "
            f"(contact {self._recovery.in_a_row} of {MAX_CONTACTS})"
        )
        self._arrival.anew()
        self._progress_watch.recovering(tick.now)
        self._stage, self._then = Stage.HALTING, self._back_off
        return self._halting(tick)

    def _back_off(self, tick: Tick) -> list[Command]:
        """BACKING_OFF straight back the way it came, then on with the recovery."""
        walls = self.navigator.walls if self.navigator is not None else None
        distance = self._recovery.back_off(tick.pose, walls)
        if distance <= 0:
            return self._after_contact(tick)
        self._traces.append(self.executor.trace)
        self.executor = Executor([Reverse(tick.pose, distance)], self.limits, self.tick)
        self._stage, self._then = Stage.BACKING_OFF, self._after_contact
        return self._backing_off(tick)

    def _after_contact(self, tick: Tick) -> list[Command]:
        """Clear of the contact: put it on the grid if something unknown is there
        (recovery.py), look for a marker until one has fixed the pose since (with
        markers known to find the robot by), then plan again. A contact is something
        the filter did not see coming: most often the casters turned the robot further
        than expected after a turn on the spot (§3.2.1.5), and a robot whose heading was
        23 degrees off what it believed touched the same box three times over, planning
        each try from the heading it believed (issue 25's scanned home)."""
        contact = self._recovery.contacts[-1]
        if contact.unknown_obstacle and self.navigator is not None:
            self.navigator.report_obstacles([contact.point], margin=FELT_EXTENT_M)
            self._felt.append(contact.point)
        estimate = tick.estimate
        if estimate is not None and self._markers() and estimate.contact:
            self._start_look(estimate, None, LookFor.CONTACT)
            return self._looking(tick)
        return self._plan_again(tick)

    # -- what interrupts a drive ---------------------------------------------------------

    def _interrupt(self, tick: Tick) -> None:
        """While driving: a door shut on the route, or the estimate lost or moved,
        stops the robot to go round, look, or plan again."""
        closed = self.navigator.state.closed if self.navigator is not None else frozenset()
        if closed != self._closed:
            self._closed = closed
            if closed & set(self._doors):
                # The operator shut a door on the route: round it, from a stop.
                self.notify(f"{self.name}: {', '.join(sorted(closed & set(self._doors)))} "
                            "closed on the route; stopping to go round")  # fmt: skip
                self._arrival.anew()
                self._stop_then(tick.now, "a door closed on the route", self._plan_again)
                return
        estimate = tick.estimate
        if estimate is None:
            return
        if estimate.lost and not settling(estimate):
            stopping = "stopping" if self._set_off else "before setting off"
            self.notify(f"{self.name}: {how_lost(estimate)}; {stopping} to look for a "
                        "marker")  # fmt: skip
            self._stop_then(tick.now, "looking for a marker", self._look_now)
        elif not self._set_off and moved(self._planned_from, estimate.pose):
            # The first marker seen puts the robot where it says: the plan starts
            # somewhere else.
            self._stop_then(tick.now, "a marker moved the pose", self._plan_again)

    def _mind_the_estimate(self, estimate: Estimate | None) -> None:
        """A plan made before the mission knew it had markers to mind is slowed where
        the robot will be unsure, before it sets off."""
        if (estimate is not None) == self._minding:
            return
        self._minding = estimate is not None
        if estimate is not None and not self._set_off and self._stage is Stage.DRIVING:
            self._unsure_start = estimate.unsure
            self.executor = self._executor_for(self._sections)
            self.time_optimal = self.executor.time_optimal

    # -- arriving -----------------------------------------------------------------------

    def _arrive(self, tick: Tick) -> list[Command]:
        """The plan is driven: arrived, or what arrival.py says to do first."""
        estimate, pose = tick.estimate, tick.pose
        if estimate is None:
            raw = self._estimate() if self._estimate is not None else None
            self._end(Outcome.ARRIVED_UNVERIFIED, by_odometry(raw))
            return []
        goal, heading = self._goal
        judged = self._arrival.judge(pose, estimate, goal, heading)
        verdict = judged.verdict
        if verdict is Verdict.GIVE_UP:
            return self._fail(tick, Outcome.BLOCKED, f"{judged.detail}; drive the robot "
                              f"there by hand, or type {self.retry} again")  # fmt: skip
        if verdict in (Verdict.ARRIVED, Verdict.UNCONFIRMED):
            if judged.settled:
                self.notify(f"{self.name}: arrived as near as it could, {judged.off:.2f} m "
                            f"off by the estimate, known to ±{estimate.sigma_m:.2f} m")  # fmt: skip
            outcome = Outcome.ARRIVED if verdict is Verdict.ARRIVED else Outcome.ARRIVED_UNVERIFIED
            self._end(outcome, judged.detail)
            return []
        # The look or the new approach is not the way getting no nearer.
        self._progress_watch.restart(tick.now)
        if verdict is Verdict.LOOK:
            self._start_look(estimate, heading, LookFor.ARRIVAL)
            return self._looking(tick)
        if verdict is Verdict.COME_IN_AGAIN:
            self.notify(f"{self.name}: {judged.detail}; coming in again")
            self._replan(pose, estimate, turned=True)
            return []
        assert heading is not None  # Verdict.TURN
        self._traces.append(self.executor.trace)
        turn = Rotation(pose, wrap(heading - pose.heading))
        self.executor = Executor([turn], self.limits, self.tick)
        self._stage = Stage.TURNING
        return []

    # -- planning -----------------------------------------------------------------------

    def _replan(self, pose: Pose, estimate: Estimate | None, turned: bool = False,
                again: bool = False) -> bool:  # fmt: skip
        """DRIVING a new plan from `pose`, its start slowly while `estimate` is unsure,
        and after a turn on the spot (`turned`: a look) while the casters settle; False,
        with the mission ended BLOCKED, if there is no way. Before the robot has moved (a
        first look moved the pose it assumed) this is the mission's first plan, not a new
        way: its progress is watched from here; but one made `again` after a stop for
        something in the way before setting off is a plan that came to nothing,
        counted, or a way blocked from the start would be planned for ever."""
        first = not self._set_off
        self._traces.append(self.executor.trace)
        self._unsure_start = estimate is not None and estimate.unsure
        self._turned = turned
        try:
            self.executor = self._plan(pose)
        except PlanningError as error:
            if not self._felt:
                self._end(Outcome.BLOCKED, str(error))
                return False
            # What it felt closed the only way: a frame clipped on a pose error reads
            # as something unknown there. The way is tried again (recovery.py's
            # MAX_CONTACTS bounds the tries), never given up for a belief of its own.
            self._forget_felt()
            self.notify(f"{self.name}: no other way; trying the same way again")
            return self._replan(pose, estimate, turned, again)
        self._stage = Stage.DRIVING
        self._recovery.replanned(self.executor.remaining())
        if first:
            self.time_optimal = self.executor.time_optimal
            if again:
                self._progress_watch.replanned(self.executor.remaining())
            else:
                self._progress_watch = ProgressWatch(self._progress_watch.patience, self._now,
                                                     self.executor.remaining())  # fmt: skip
            return True
        self.replans += 1
        through = f" through {', '.join(self._doors)}" if self._doors else ""
        self.notify(f"{self.name}: new way, {self.executor.remaining():.1f} m{through}")
        return True

    def _stuck(self, pose: Pose, how: str) -> str:
        """Why the mission gives up (`how`, where `{}` is put where the robot is), and
        what the operator can do about it."""
        # What is on the grid near it: the range finder's, or what it felt (a robot
        # without one has only the latter).
        sensed = self.navigator.state.obstacles if self.navigator is not None else ()
        near = any(math.dist((pose.x, pose.y), point) <= CAUSE_NEAR_M for point in sensed)
        cause = "something blocks the way" if near else "nothing seen, but no progress"
        where = how.format(f"({pose.x:.1f}, {pose.y:.1f})")
        return f"{where}: {cause}; clear the way and type {self.retry} again, or drive by hand"

    def _plan(self, pose: Pose) -> Executor:
        course = self._course(pose)
        legs = self.navigator.planner.legs if self.navigator is not None else None
        sections = shape(course.points, pose.heading, course.goal_heading,
                         legs.clear if legs is not None else None, self.turn_limits,
                         course.doorways)  # fmt: skip
        self.planned = course.planned
        self._planned_from = pose
        self._goal = (course.points[-1], course.goal_heading)
        self._doors = course.doors
        self._closed = self.navigator.state.closed if self.navigator is not None else frozenset()
        if self._lookout is not None:
            self._lookout.new_plan(course.planned)
        plan = self.navigator.plan if self.navigator is not None else None
        doors = [door.at for door in plan.doors if door.id in course.doors] if plan else []
        self._sections, self._door_points = sections, doors
        self._crossings = course.doorways
        return self._executor_for(sections)

    def _executor_for(self, sections: Sequence[Section]) -> Executor:
        """The executor of a plan's `sections`: slowly through its doorways, and, minding
        the estimate, where the robot will be unsure of where it is (certainty.py)."""
        limits, doors = self.limits, self._door_points
        slow = slow_stretches(sections, self._unsure_start, self._turned) if self._minding else {}
        cap = limits.v_max * SLOW_FRACTION

        def zones(drive: Drive) -> list[SlowZone]:
            found = _door_zones(drive, doors, limits.door_speed)
            stretch = min(slow.get(id(drive), 0.0), drive.length)
            if stretch > 0:
                found.append(SlowZone(0.0, stretch, cap))
            return found

        executor = Executor(sections, limits, self.tick, zones)
        self._total = executor.remaining()
        return executor

    # -- sensing (lookout.py) -----------------------------------------------------------

    def _watch(self, tick: Tick) -> None:
        """The range finder's sweep into the grid (while stopping too, so that the new
        plan knows all it can); if the grid now blocks the path ahead, stop and plan
        again (D* Lite across this room, else the room graph); and so, once for each
        door, if a doorway ahead is seen off where the plan crosses it."""
        assert self._lookout is not None
        pose = tick.pose
        self._lookout.sweep(pose, tick.now)
        if self._stage is not Stage.DRIVING:
            return
        if self._lookout.blocks(self.executor):
            self.notify(f"{self.name}: something in the way ahead of ({pose.x:.1f}, "
                        f"{pose.y:.1f}); stopping to plan again")  # fmt: skip
            self._arrival.anew()
            self._stop_then(tick.now, "something in the way", self._plan_again_blocked)
            return
        off = self._lookout.doorway_off(pose, self._doors, self._crossings)
        if off is not None:
            door, over = off
            self.notify(f"{self.name}: {door}'s doorway seen off the plan, its crossing "
                        f"{100 * over:.0f} cm over; stopping to plan again")  # fmt: skip
            self._arrival.anew()
            self._stop_then(tick.now, "a doorway seen off the plan", self._plan_again)

    def _plan_again_blocked(self, tick: Tick) -> list[Command]:
        return self._plan_again(tick, blocked=True)


def _door_zones(drive: Drive, doors: list[tuple[float, float]], speed: float) -> list[SlowZone]:
    """Slow zones where the drive passes through the doors of its route."""
    zones = []
    step = 0.05
    count = max(2, math.ceil(drive.length / step) + 1)
    samples = [(i * drive.length / (count - 1)) for i in range(count)]
    poses = [drive.pose_at(s) for s in samples]
    for door in doors:
        distances = [math.hypot(p.x - door[0], p.y - door[1]) for p in poses]
        best = min(range(count), key=distances.__getitem__)
        if distances[best] <= DOOR_ZONE_M:
            at = samples[best]
            zones.append(SlowZone(max(0.0, at - DOOR_ZONE_M), min(drive.length, at + DOOR_ZONE_M),
                                  speed))  # fmt: skip
    return zones
