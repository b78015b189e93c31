"""A mission that drives a planned path: shape, drive and watch (thesis §2.7, §2.4).

The planned polyline is shaped into clothoid turns the board can drive without a jump in
its gear ratio (motion/shaping.py), given a jerk-limited speed profile and streamed to
the board tick by tick, steering back onto the path from the odometry
(motion/executor.py). `go <room>` and a taught route followed closed-loop are both this;
they differ in where the path comes from.

While driving, the range finder (§2.4, §6) reports what is ahead. Obstacles go into the
grid, what its beams now see through comes out again (a box taken away), and the D* Lite
planner of the leg the robot is on is told of both, so that it replans incrementally.
If the path ahead is blocked, the robot comes to a jerk-limited stop and sets off on a
new path from where it stands. A stall (motion commanded, the wheels not
turning: §2.3.2), no way left, or no progress for long (progress_watch.py: something in
the way that no new plan gets round) ends the mission with the reason and what to do;
ESTOP, a lost link and the operator's keys end it in the control loop. The control loop
stops the robot when a mission ends with a problem.

With an `estimate` from a plan with markers (issue 14), the mission also minds how well
the robot knows where it is, by the bounds of certainty.py. Never found by a marker since
the start, it looks for one before it sets off (localising.py); unsure, it drives slower;
lost, it comes to a stop, looks, and plans again from where the marker says it is; and
it arrives only once the estimate is known well enough and at the goal, looking and
coming in again if need be. Its turns on the spot are steered as steady_turn.py says.
Without markers it drives by the odometry as it always has.

What `progress` gives is the plan under way: while the robot stops to plan again it
says so rather than giving the few centimetres of braking left, and when the robot
gets no nearer it says for how long rather than an ETA.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Protocol

import numpy as np

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.certainty import (
    AFTER_REAPPROACH_M,
    ARRIVAL_TRIES,
    NEAR_ENOUGH_HEADING,
    NEAR_ENOUGH_M,
    REAPPROACH_M,
    SLOW_FRACTION,
    confirmed,
    how_lost,
    lost,
    lost_again,
    moved,
    settling,
    slow_stretches,
    sure,
)
from giraff_console.missions.localising import Look, Outcome
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.progress_watch import Patience, ProgressWatch
from giraff_console.missions.steady_turn import SteadyTurn
from giraff_console.motion.executor import Executor, Trace
from giraff_console.motion.path import Drive, Rotation, Section, wrap
from giraff_console.motion.shaping import ALIGNED_RAD, TurnLimits, shape
from giraff_console.motion.speed_profile import MotionLimits, SlowZone
from giraff_console.planning.landmarks import marker_poses
from giraff_console.planning.legs import Leg
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import PlannedPath
from giraff_console.planning.walls import wall_segments
from giraff_console.protocol.codec import Command
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import ARRIVED, DRIVING, PAUSED, Progress
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]


class Scan(Protocol):
    """One sweep of a range finder, as a LIDAR's scan message has it: each beam's
    (distance, bearing) in the robot's frame, bearing positive left; a distance beyond
    `range_max` (ROS REP 117's +inf) says the beam met nothing within range."""

    @property
    def range_max(self) -> float: ...

    @property
    def beams(self) -> Sequence[tuple[float, float]]: ...


Sense = Callable[[], Scan]

# How far along the path ahead sensed obstacles are looked for.
LOOKOUT_M = 3.0
# A doorway is passed slowly this far either side of its centre.
DOOR_ZONE_M = 0.4
# After this long without progress, the progress line says so instead of an ETA.
SHOW_STILL_S = 5.0
# Leaving the margin round a sensed obstacle, the path may come this much closer to it:
# the samples of a path along the obstacle's side wobble by a few millimetres.
MARGIN_TOLERANCE_M = 0.01
# Sensed obstacles this close to the robot are what a stuck mission names as the cause.
CAUSE_NEAR_M = 1.5


@dataclass(frozen=True)
class Course:
    """Where a path mission drives from a pose: the polyline and what it passes."""

    points: list[Point]
    goal_heading: float | None = None  # radians; None: whatever the path ends with
    doorways: frozenset[Point] = frozenset()  # crossed straight (shaping's pins)
    doors: tuple[str, ...] = ()  # the doors passed, by id
    planned: PlannedPath | None = None  # the room graph's route, for D* Lite replanning


class PathMission:
    """A Mission that drives the course `_course` gives, replanning round obstacles.

    Planning happens when the mission is made (PlanningError if there is no way), so
    the console makes it off its UI thread.
    """

    name: str
    retry: str  # what the operator types to try again
    # Set by _plan, which __init__ calls.
    _sections: tuple[Section, ...]
    _closed: frozenset[str]

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
    ) -> None:
        """`notify` gets a line for the operator when the mission changes its plan;
        `patience` says how long it may go without getting nearer before it gives up.
        `estimate`, called on the control loop's thread when the mission is stepped,
        says how well `pose` is known (see the module docstring); without it, or
        while the plan has no markers, the mission steers by `pose` alone."""
        self.navigator = navigator
        self.notify = notify
        self.limits = limits or MotionLimits()
        self.turn_limits = turn_limits or TurnLimits()
        self.tick = tick
        self._pose = pose
        self._sense = sense if navigator is not None else None
        self.problem: str | None = None
        self.replans = 0
        self._started: float | None = None
        self._ended: float | None = None
        self._now = 0.0
        self._paused = False
        self._restart = False  # set off again on a new plan once the robot is still
        self._restart_why = ""
        # The traces of the plans driven before the present one (after replanning).
        self._traces: list[Trace] = []
        self._leg: Leg | None = None
        self._leg_index = -1
        self._estimate = estimate
        self._markers = marker_poses(navigator.plan) if navigator is not None else {}
        self._look: Look | None = None
        self._look_next = False  # look once stopped, rather than plan again at once
        self._set_off = False  # the robot has been commanded to move
        # With markers to find the robot by, plans are slowed where it will be unsure:
        # from their start when made unsure, and after turns on the spot (`turned`: it
        # has just turned before the plan starts).
        self._minding = False
        self._unsure_start = False
        self._turned = False
        self._arrival_tries = 0
        self._came_in_again = False  # so it settles within AFTER_REAPPROACH_M
        # Arriving, the estimate is taken as it is: a look found no better, or the plan
        # under way is the turn to the goal's heading after one.
        self._as_known = False
        self._steady_turn = SteadyTurn()
        self._look_kind = "lost"
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

    # -- the Mission protocol -----------------------------------------------------------

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        self._now = now
        if self._started is None:
            self._started = now
            self._progress_watch.restart(now)
        if self._paused or state is None or self.finished or self.problem is not None:
            return []
        pose = self._pose()
        if self._sense is not None:
            self._watch(now, pose)
        estimate = self._estimate() if self._estimate is not None else None
        if estimate is not None and not estimate.landmarks:
            estimate = None  # no markers to find the robot by: the odometry is all there is
        if (estimate is not None) != self._minding:
            self._minding = estimate is not None
            if estimate is not None and not self._set_off and not self._restart:
                # The plan made before the mission knew: slowed where it will be unsure.
                self._unsure_start = estimate.unsure
                self.executor = self._executor_for(self._sections)
                self.time_optimal = self.executor.time_optimal
        if self._look is not None:
            if estimate is not None:
                return self._step_look(now, state, estimate, pose)
            self._drop_look()  # the markers were taken away: plan again, by the odometry
            self._restart, self._restart_why = True, "no markers any more"
        closed = self.navigator.state.closed if self.navigator is not None else frozenset()
        if closed != self._closed:
            self._closed = closed
            if closed & set(self._doors) and not self._restart:
                # The operator shut a door on the route: round it, from a stop.
                self.notify(f"{self.name}: {', '.join(sorted(closed & set(self._doors)))} "
                            "closed on the route; stopping to go round")  # fmt: skip
                self.executor.brake(now)
                self._restart, self._restart_why = True, "a door closed on the route"
                self._approach_anew()
        if estimate is not None:
            self._mind(now, estimate)
        watch = self._progress_watch
        if watch.stuck(now):
            self.problem = self._stuck(pose, f"stuck for {watch.still_for(now):.0f} s near {{}}")
            return []
        if self._restart and self.executor.finished:
            if state.moving:
                return []
            if self._look_next and estimate is not None:
                self._look_next = False
                if watch.out_of_looks():
                    self.problem = lost_again(pose, watch.looks, self.retry)
                    return []
                self._look = self._make_look(estimate, None, "lost")
                return self._step_look(now, state, estimate, pose)
            self._look_next = False
            if watch.out_of_replans():
                self.problem = self._stuck(pose, f"stuck near {{}} after {watch.replans} new "
                                                 "ways in a row that got no nearer")  # fmt: skip
                return []
            first = not self._set_off
            if not self._replan(pose, estimate):
                return []
            if not first:
                watch.replanned(self.executor.remaining())
        steer = pose
        if estimate is not None:
            steer = self._steady_turn.pose(self.executor, pose, estimate.odometry)
        casters = estimate.caster_rate if estimate is not None else 0.0
        commands = self.executor.step(now, state, steer, casters)
        self._set_off = self._set_off or bool(commands)
        if self.executor.problem is not None:
            self.problem = self.executor.problem
        elif self.executor.finished and not self._restart:
            self._arrive(now, estimate, pose)
        elif not self._restart:
            # While braking for a new plan, what is left of the old one is not progress.
            watch.driven(now, self.executor.remaining())
        return commands

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        """The loop stops the robot; on resuming, the rest is planned from where it is."""
        self._paused = True

    def resume(self, now: float) -> None:
        if self._paused:
            self._paused = False
            self._drop_look()  # a look, if it still must, starts again from the stop
            self.executor.abandon()
            self._restart, self._restart_why = True, "resuming"
            self._approach_anew()  # it may have been driven anywhere by hand meanwhile
            self._progress_watch.restart(now)

    @property
    def finished(self) -> bool:
        return self._ended is not None

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
        if self._look is not None:
            return Progress(self.name, self._look.state, total_m=self._total)
        if self._restart:
            # The plan being given up says nothing true of the way left: the braking
            # metres of the old one would read as nearly there.
            why = f"stopping to plan a new way ({self._restart_why})"
            return Progress(self.name, why, total_m=self._total)
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

    # -- knowing where it is (issue 14) --------------------------------------------------

    def _mind(self, now: float, estimate: Estimate) -> None:
        """Lost: come to a stop to look for a marker. Moved by a marker before setting
        off: plan again from there."""
        if estimate.lost and not settling(estimate):
            if not self._look_next:
                self._look_next = True
                stopping = "stopping" if self._set_off else "before setting off"
                self.notify(f"{self.name}: {how_lost(estimate)}; {stopping} to look for a "
                            "marker")  # fmt: skip
                self.executor.brake(now)
                self._restart, self._restart_why = True, "looking for a marker"
        elif not self._set_off and not self._restart and moved(self._planned_from, estimate.pose):
            # The first marker seen puts the robot where it says: the plan starts
            # somewhere else.
            self.executor.brake(now)
            self._restart, self._restart_why = True, "a marker moved the pose"

    def _replan(self, pose: Pose, estimate: Estimate | None, turned: bool = False) -> bool:
        """Plan again from `pose`, its start slowly while `estimate` is unsure, and after
        a turn on the spot (`turned`: a look) while the casters settle; False, with the
        problem set, if there is no way. Before the robot has moved (a first look moved
        the pose it assumed) this is the mission's first plan, not a new way: its
        progress is watched from here."""
        first = not self._set_off
        self._traces.append(self.executor.trace)
        if first:
            self._restart = False  # the way from where the robot is is no way round
        self._unsure_start = estimate is not None and estimate.unsure
        self._turned = turned
        try:
            self.executor = self._plan(pose)
        except PlanningError as error:
            self.problem = str(error)
            return False
        self._restart = False
        if first:
            self.time_optimal = self.executor.time_optimal
            self._progress_watch = ProgressWatch(self._progress_watch.patience, self._now,
                                                 self.executor.remaining())  # fmt: skip
            return True
        self.replans += 1
        through = f" through {', '.join(self._doors)}" if self._doors else ""
        self.notify(f"{self.name}: new way, {self.executor.remaining():.1f} m{through}")
        return True

    def _make_look(self, estimate: Estimate, prefer: float | None, kind: str) -> Look:
        """A look for a marker: `kind` "lost" until the estimate is back under the slow
        bound, "arrival" until it is within the arrival bounds."""
        navigator = self.navigator
        walls = wall_segments(navigator.plan, navigator.state.closed) if navigator else []
        if kind == "arrival":
            why = f"arrived, known to ±{estimate.sigma_m:.2f} m: looking for a marker"
            enough = confirmed
        else:
            why = f"{how_lost(estimate)}: looking for a marker"
            enough = sure
        self._look_kind = kind
        return Look(estimate, self._markers, walls, limits=self.limits, tick=self.tick,
                    enough=enough, prefer=prefer, why=why)  # fmt: skip

    def _step_look(self, now: float, state: MotorState, estimate: Estimate,
                   pose: Pose) -> list[Command]:  # fmt: skip
        look = self._look
        assert look is not None
        commands = look.step(now, state, estimate)
        if look.problem is not None:
            self.problem = look.problem
            return []
        if not look.finished:
            return commands
        self._drop_look()
        if look.outcome is Outcome.NOT_FOUND and estimate.lost:
            self.problem = lost(estimate, self.retry)
            return []
        if self._look_kind == "arrival":
            if look.outcome is Outcome.NOT_FOUND:
                self.notify(f"{self.name}: no marker in sight to confirm the arrival "
                            f"(±{estimate.sigma_m:.2f} m)")  # fmt: skip
            self._as_known = look.outcome is not Outcome.FOUND  # no use looking again
            self._arrive(now, estimate, pose)
            return commands
        seen = ", ".join(str(i) for i in estimate.seen) or "a marker"
        self.notify(f"{self.name}: found by {seen}, ±{estimate.sigma_m:.2f} m; carrying on")
        first = not self._set_off
        if first and self._arrived_already(pose):
            self._started = self._ended = now
            return commands
        self._restart = True
        if self._replan(pose, estimate, turned=True):
            # Before setting off too: a robot that keeps finding markers too far to be sure
            # by must not turn on the spot for ever.
            self._progress_watch.looked(now - (look.started_at or now), self.executor.remaining())
        return commands

    def _arrive(self, now: float, estimate: Estimate | None, pose: Pose) -> None:
        """The plan is driven. With markers the robot has arrived once the estimate is
        within the arrival bounds (else it looks for a marker) and at the goal (else it
        comes in again, or turns to the goal's heading); having come in again, it settles
        within AFTER_REAPPROACH_M; after ARRIVAL_TRIES of those it settles for what it
        has, and says so."""
        goal, heading = self._goal
        off = math.dist((pose.x, pose.y), goal)
        near = AFTER_REAPPROACH_M if self._came_in_again else REAPPROACH_M
        turned = heading is not None and abs(wrap(heading - pose.heading)) > ALIGNED_RAD
        # The turn to the goal's heading after a look adds only the wheels' error over
        # that turn, which looking again, turning away and back, would not take out.
        known = estimate is None or self._as_known or confirmed(estimate)
        if estimate is None or (known and off <= near and not turned):
            self._ended = now
            return
        if self._arrival_tries >= ARRIVAL_TRIES:
            askew = 0.0 if heading is None else abs(wrap(heading - pose.heading))
            if off > NEAR_ENOUGH_M or askew > NEAR_ENOUGH_HEADING:
                self.problem = (f"could not get nearer than {off:.2f} m and "
                                f"{math.degrees(askew):.0f}° to the goal (by the estimate, "
                                f"known to ±{estimate.sigma_m:.2f} m) after {ARRIVAL_TRIES} "
                                f"tries; drive the robot there by hand, or type "
                                f"{self.retry} again")  # fmt: skip
                return
            self.notify(f"{self.name}: arrived as near as it could, {off:.2f} m off by the "
                        f"estimate, known to ±{estimate.sigma_m:.2f} m")  # fmt: skip
            self._ended = now
            return
        self._arrival_tries += 1
        self._as_known = False
        # The look or the new approach is not the way getting no nearer.
        self._progress_watch.restart(now)
        if not known:
            self._look = self._make_look(estimate, heading, "arrival")
        elif off > near:
            self.notify(f"{self.name}: {off:.2f} m off the goal by the markers; coming in again")
            self._restart, self._restart_why = True, "coming in again"
            self._came_in_again = True
            self._replan(pose, estimate, turned=True)
        else:
            assert heading is not None
            self._traces.append(self.executor.trace)
            turn = Rotation(pose, wrap(heading - pose.heading))
            self.executor = Executor([turn], self.limits, self.tick)
            self._as_known = True

    def _approach_anew(self) -> None:
        """A way round, or from wherever it was driven by hand, is a new approach: its
        arrival is judged afresh, with all its tries."""
        self._arrival_tries = 0
        self._came_in_again = False

    def _drop_look(self) -> None:
        if self._look is not None:
            self._traces.extend(self._look.traces)
            self._look = None

    # -- inside -------------------------------------------------------------------------

    def _stuck(self, pose: Pose, how: str) -> str:
        """Why the mission gives up (`how`, where `{}` is put where the robot is), and
        what the operator can do about it."""
        near = self._sensed_near(pose, CAUSE_NEAR_M)
        cause = "something blocks the way" if near else "nothing seen, but no progress"
        where = how.format(f"({pose.x:.1f}, {pose.y:.1f})")
        return f"{where}: {cause}; clear the way and type {self.retry} again, or drive by hand"

    def _sensed_near(self, pose: Pose, reach: float) -> bool:
        """Whether the range finder has seen anything within `reach` of `pose`."""
        sensed = self.navigator.state.obstacles if self.navigator is not None else ()
        return any(math.dist((pose.x, pose.y), point) <= reach for point in sensed)

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
        self._leg, self._leg_index = None, -1
        plan = self.navigator.plan if self.navigator is not None else None
        doors = [door.at for door in plan.doors if door.id in course.doors] if plan else []
        self._sections, self._door_points = sections, doors
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

    def _watch(self, now: float, pose: Pose) -> None:
        """Put what the range finder sees into the grid, and take out what its beams now
        see through (while stopping too, so that the new plan knows all it can); if the
        grid now blocks the path ahead, stop and plan again (D* Lite across this room,
        else the room graph)."""
        assert self._sense is not None and self.navigator is not None
        scan = self._sense()
        hits: list[Point] = []
        free: list[Point] = []
        for distance, bearing in scan.beams:
            if math.isnan(distance):
                continue  # a failed measurement (REP 117) says nothing either way
            seen = distance <= scan.range_max
            reach = distance if seen else scan.range_max
            angle = pose.heading + bearing
            end = (pose.x + reach * math.cos(angle), pose.y + reach * math.sin(angle))
            (hits if seen else free).append(end)
        changes = self.navigator.report_obstacles(hits, (pose.x, pose.y), free)
        if changes:
            leg = self._current_leg(pose)
            if leg is not None:
                leg.update(changes)
        if self._restart or not self.navigator.state.obstacles:
            return
        if self._blocks_path_ahead():
            self.notify(f"{self.name}: something in the way ahead of ({pose.x:.1f}, "
                        f"{pose.y:.1f}); stopping to plan again")  # fmt: skip
            self.executor.brake(now)
            self._restart, self._restart_why = True, "something in the way"
            self._approach_anew()

    def _blocks_path_ahead(self) -> bool:
        """Whether the grid, as it now is, blocks the path within LOOKOUT_M ahead: of
        the drive under way, or of the next one after a turn on the spot."""
        legs = self.navigator.planner.legs if self.navigator is not None else None
        executor = self.executor
        if legs is None or executor.finished:
            return False
        drives = [s for s in executor.sections[executor.index :] if isinstance(s, Drive)]
        if not drives:
            return False
        section = drives[0]
        start = executor.progress if section is executor.sections[executor.index] else 0.0
        end = min(section.length, start + LOOKOUT_M)
        samples = max(2, math.ceil((end - start) / 0.05) + 1)
        points = []
        for i in range(samples):
            p = section.pose_at(start + (end - start) * i / (samples - 1))
            points.append((p.x, p.y))
        return not all(legs.clear(a, b) for a, b in pairwise(self._past_margin(points)))

    def _past_margin(self, points: list[Point]) -> list[Point]:
        """The path ahead from where it leaves the margin round what was sensed, when
        the robot stands in that margin and the path takes it no closer.

        A box put down beside the robot blocks the grid's cells under the robot itself
        (they are grown by its radius and the clearance), so every new plan would look
        blocked at once and be given up: the robot stopped and replanned for ever. A
        path that heads away from the box, or past it no closer, is the way out; one
        that heads closer is still blocked."""
        assert self.navigator is not None
        legs = self.navigator.planner.legs
        sensed = self.navigator.state.obstacles
        if legs is None or not sensed:
            return points

        seen = np.asarray(sensed)

        def nearest(point: Point) -> float:
            return float(np.hypot(seen[:, 0] - point[0], seen[:, 1] - point[1]).min())

        # Measured from where the path starts, not sample to sample: a path may not
        # creep in a little at a time.
        floor = nearest(points[0]) - MARGIN_TOLERANCE_M
        for i, point in enumerate(points):
            if legs.clear(point, point) or nearest(point) < floor:
                return points[i:]  # out of the margin, or closer in: the grid decides
        return points[-1:]

    def _current_leg(self, pose: Pose) -> Leg | None:
        """The D* Lite planner of the leg the robot is on, kept from one sighting to the
        next so that each replans incrementally."""
        if self.navigator is None or self.planned is None:
            return None
        legs = self.navigator.planner.legs
        route = self.planned.route
        if legs is None or len(route.path) < 2:
            return None
        here = (pose.x, pose.y)
        index = min(
            range(len(route.path) - 1),
            key=lambda i: _distance_to_segment(here, route.path[i], route.path[i + 1]),
        )
        if self._leg is None or index != self._leg_index:
            self._leg = legs.leg(here, route.path[index + 1], route.leg_rooms[index])
            self._leg_index = index
        self._leg.move_to(here)
        return self._leg


def _distance_to_segment(p: tuple[float, float], a: tuple[float, float],
                         b: tuple[float, float]) -> float:  # fmt: skip
    dx, dy = b[0] - a[0], b[1] - a[1]
    span = dx * dx + dy * dy
    t = 0.0 if span == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / span))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


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
