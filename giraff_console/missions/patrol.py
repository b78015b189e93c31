"""Patrols: taught routes driven round after round, stopping to look at each stop.

§1.2 looks ahead to "fully autonomous daily or nightly patrols, looking for anomalies",
and §2.5 has destinations chosen "by preprogramming some patrol route". Until the
console can plan its way to a room (§2.6.2, §2.6.3), a patrol is a chain of taught
routes (§2.6.1), each starting where the one before ended: the robot drives a route,
the console takes a picture for the caregiver, the robot waits there a while, then
drives on. Replays are open-loop, so the error of every round adds up: a patrol should
end where it began, where the operator can see how far it drifted.

A patrol file is `routes/<name>.patrol.yaml`; routes/README.md describes it.

A stop that fails on the way (the robot touched something again and again, or found no
way there) does not end the patrol (issue 25): the failed mission brings the robot to
rest, the stop is reported with its outcome and why, and the patrol goes on to the
next stop, unless the file says `carry_on: false`. A robot that does not know where it
is (LOST, UNVERIFIED) or a failure of the board ends it: going on would drive blind.

On a board with a charger, a patrol that finds its battery low once it has finished a
stop goes to the dock, charges, and carries on (missions/docking.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.docking import ChargingDetour, Recharge
from giraff_console.missions.names import PATROL_SUFFIX
from giraff_console.missions.path_mission import PathMission
from giraff_console.missions.route import Route
from giraff_console.missions.route_replay import RouteReplay, replay_refusal
from giraff_console.missions.yaml_file import YamlFile, shown
from giraff_console.planning.room_graph import PlanningError
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import GiraffError
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import Mission, Outcome, Progress
from giraff_console.robot.odometry import Pose

# A patrol is planned as a list of every leg of every round, so rounds are bounded; this
# many rounds of one short stop is weeks of driving.
MAX_ROUNDS = 10_000
# The failures of a stop after which a patrol carries on to the next (with carry_on):
# the robot is at rest and knows where it is, and the next stop may be reachable.
CARRY_ON_AFTER = frozenset({Outcome.STALLED, Outcome.BLOCKED})


class PatrolError(GiraffError):
    """A patrol that cannot be read or run; the message says why."""


@dataclass(frozen=True)
class Stop:
    """Drive the taught route `route` (replayed, or followed closed-loop with `follow`),
    or go to the floor plan's room `room`; then wait `dwell` seconds there."""

    route: str | None
    dwell: float
    room: str | None = None
    follow: bool = False

    @property
    def place(self) -> str:
        """What the stop drives to, for the operator: the room, or the route's name."""
        return self.room if self.room is not None else str(self.route)


@dataclass(frozen=True)
class Patrol:
    """A patrol file: `rounds` times over, each stop in turn."""

    name: str
    rounds: int
    snapshots: bool
    stops: list[Stop]
    carry_on: bool = True  # on to the next stop after one that failed (CARRY_ON_AFTER)


@dataclass(frozen=True)
class StopReached:
    """A stop's leg has ended: the robot came to rest at the end of its route, or the
    leg failed and the patrol goes on; both numbers count from 1. `outcome` is the
    leg's (a taught route replayed has none of its own: ARRIVED_UNVERIFIED) and
    `detail` its words."""

    round: int
    stop_index: int
    route_name: str
    outcome: Outcome = Outcome.ARRIVED_UNVERIFIED
    detail: str = ""
    # The leg's largest jerk (m/s^3) as commanded, where it was a path mission's.
    max_jerk: float | None = None

    @property
    def reached(self) -> bool:
        return self.outcome.arrived


def load_patrol(path: Path) -> Patrol:
    """Read a patrol file; PatrolError names the file and what is wrong with it."""
    file = YamlFile(Path(path), PatrolError)
    if not file.path.name.endswith(PATROL_SUFFIX):
        file.fail(f"a patrol file's name ends in {PATROL_SUFFIX}")
    name = file.name(file.path.name.removesuffix(PATROL_SUFFIX), "patrol")
    doc = file.mapping(required=("rounds", "stops"), optional=("snapshots", "carry_on"))
    rounds = doc["rounds"]
    if isinstance(rounds, bool) or not isinstance(rounds, int) or not 1 <= rounds <= MAX_ROUNDS:
        file.fail(
            f"rounds should be a whole number from 1 to {MAX_ROUNDS}, not {shown(rounds)}", "rounds"
        )
    snapshots = doc.get("snapshots", True)
    if not isinstance(snapshots, bool):
        file.fail(f"snapshots should be true or false, not {shown(snapshots)}", "snapshots")
    carry_on = doc.get("carry_on", True)
    if not isinstance(carry_on, bool):
        file.fail(f"carry_on should be true or false, not {shown(carry_on)}", "carry_on")
    stops = doc["stops"]
    if not isinstance(stops, list) or not stops:
        file.fail("stops should be a list of {route: NAME} or {room: ROOM}, at least one", "stops")
    file.within_limit(stops, "stops", "stops")
    return Patrol(
        name,
        rounds,
        snapshots,
        [_stop(file, s, f"stops[{i}]") for i, s in enumerate(stops)],
        carry_on,
    )


def _stop(file: YamlFile, item: object, where: str) -> Stop:
    fields = file.table(item, where, ("route", "room", "follow", "dwell"), required=())
    if ("route" in fields) == ("room" in fields):
        file.fail(f"{where}: a stop names either a route or a room", where)
    dwell = file.number(fields.get("dwell", 0), f"{where}.dwell", minimum=0)
    follow = fields.get("follow", False)
    if not isinstance(follow, bool) or (follow and "room" in fields):
        file.fail(
            f"{where}.follow should be true or false, and only for a route", f"{where}.follow"
        )
    if "room" in fields:
        return Stop(None, dwell, room=file.name(fields["room"], "room", f"{where}.room"))
    return Stop(file.name(fields["route"], "route", f"{where}.route"), dwell, follow=follow)


# Missions for a stop's leg, made as the leg starts: to a room, or along a taught route
# closed-loop. They raise PlanningError when there is no way.
GoToRoom = Callable[[str], Mission]
FollowTaught = Callable[[Route], Mission]


class PatrolRun:
    """A Mission that drives a patrol: each stop's leg, a call to `on_stop`, a dwell.

    A stop's leg replays its taught route, follows it closed-loop (`go`-style), or goes
    to a room of the floor plan, with the missions `follow` and `go` make. `on_stop` is
    called on the control loop's thread, as the robot comes to rest at the end of a
    leg; the console takes its snapshot there, so it must not block.

    With `recharge`, a stop finished on a low battery is followed by a detour to the
    dock (`pose` says where the robot left off, `notify` tells the operator).
    """

    def __init__(
        self,
        patrol: Patrol,
        routes: dict[str, Route],
        on_stop: Callable[[StopReached], None] = lambda stop: None,
        *,
        go: GoToRoom | None = None,
        follow: FollowTaught | None = None,
        recharge: Recharge | None = None,
        pose: Callable[[], Pose] | None = None,
        notify: Callable[[str], None] = lambda text: None,
        estimate: Callable[[], Estimate] | None = None,
    ) -> None:
        needed = {stop.route for stop in patrol.stops if stop.route is not None}
        missing = sorted(needed - routes.keys())
        if missing:
            raise PatrolError(
                f"patrol {patrol.name} needs routes not taught yet: {', '.join(missing)}"
            )
        if go is None and any(stop.room for stop in patrol.stops):
            raise PatrolError(f"patrol {patrol.name} goes to rooms: it needs a floor plan")
        if follow is None and any(stop.follow for stop in patrol.stops):
            raise PatrolError(f"patrol {patrol.name} follows routes: it needs the console's go")
        self.patrol = patrol
        self.name = patrol.name
        self._routes = routes
        self._on_stop = on_stop
        self._go, self._follow = go, follow
        self._recharge, self._pose, self._notify = recharge, pose, notify
        self._estimate = estimate
        # (round, stop index) for every stop of every round, in the order they are made.
        self._legs = [(n, i) for n in range(1, patrol.rounds + 1) for i in range(len(patrol.stops))]
        self._leg = 0
        self._problem: str | None = None
        self._failed_in_a_row = 0
        # The stops missed, and those reached by an estimate nothing confirmed: how the
        # patrol judges its end (outcome).
        self._missed = 0
        self._unverified = 0
        self._mission: Mission = _Idle()
        self._detour: ChargingDetour | None = None
        self._dwell_end: float | None = None
        self._paused_at: float | None = None
        self._now: float | None = None
        # When it first drove (its first tick): its reports' times count from it.
        self.started_at: float | None = None
        # A patrol set off on a low battery charges first.
        self._start_leg()

    def _start_leg(self) -> None:
        """The detour to the dock, if the battery is low, else the mission that drives
        to the stop now due. A stop whose way cannot be planned is skipped as failed
        (carry_on); any other leg that cannot start ends the patrol."""
        if self.finished or self._problem is not None:
            return
        self._detour = self._charging_detour()
        if self._detour is not None:
            self._mission = _Idle()
            return
        while not self.finished and self._problem is None:
            stop = self._stop()
            try:
                self._mission = self._leg_mission(stop)
                return
            except PlanningError as error:
                why = f"stop {stop.place}: {error}"
                if not (self.patrol.carry_on and stop.room is not None):
                    self._problem, self._mission = why, _Idle()
                    return
                self._failed(Outcome.BLOCKED, why)

    def _leg_mission(self, stop: Stop) -> Mission:
        """The mission that drives to `stop`; PlanningError if there is no way."""
        if stop.room is not None:
            assert self._go is not None
            return self._go(stop.room)
        route = self._routes[str(stop.route)]
        if stop.follow:
            assert self._follow is not None
            return self._follow(route)
        estimate = self._estimate() if self._estimate else None
        refusal = replay_refusal(route, estimate, f"patrol {self.name}")
        if refusal is not None:
            raise PlanningError(f"route {route.name}: {refusal}")
        return RouteReplay(route)

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self.started_at is None:
            self.started_at = now
        if self._paused_at is not None or self.finished or self._problem is not None:
            return []
        self._now = now
        if self._dwell_end is not None:
            if now < self._dwell_end:
                return []
            self._leg, self._dwell_end = self._leg + 1, None
            if self.finished:
                return []
            self._start_leg()
        if self._detour is not None:
            commands = self._detour.step(now, state)
            if self._detour.finished:
                self._detour = None
                self._start_leg()
            return commands
        mission = self._mission
        commands = mission.step(now, state)
        path = mission if isinstance(mission, PathMission) else None
        outcome = path.outcome if path is not None else None
        if mission.finished:
            self._failed_in_a_row = 0
            self._reached(outcome or Outcome.ARRIVED_UNVERIFIED, path.detail if path else "")
            self._dwell_end = now + self._stop().dwell
        elif mission.problem is not None and self.patrol.carry_on and outcome in CARRY_ON_AFTER:
            assert outcome is not None
            self._failed(outcome, mission.problem)
            self._start_leg()
        return commands

    @property
    def outcome(self) -> Outcome | None:
        """How a patrol that went round to its end did (robot/mission.py, Judged):
        arrived at every stop, confirmed or not, or a stop missed; None before, or when
        the loop ends it on the way (the loop says how)."""
        if not self.finished:
            return None
        if self._missed:
            return Outcome.FAILED
        return Outcome.ARRIVED_UNVERIFIED if self._unverified else Outcome.ARRIVED

    @property
    def detail(self) -> str:
        if not self.finished:
            return ""
        stops = len(self._legs)
        if self._missed:
            return f"{self._missed} of {stops} stops missed"
        if self._unverified:
            return f"every stop reached; {self._unverified} of {stops} by an unconfirmed pose"
        return "every stop reached, each confirmed by a marker"

    def _reached(self, outcome: Outcome, detail: str) -> None:
        self._missed += not outcome.arrived
        self._unverified += outcome is Outcome.ARRIVED_UNVERIFIED
        round_number, index = self._legs[self._leg]
        path = self._mission if isinstance(self._mission, PathMission) else None
        jerk = path.merged_trace().max_jerk() if path is not None else None
        self._on_stop(StopReached(round_number, index + 1, self._stop().place, outcome,
                                  detail, jerk))  # fmt: skip

    def _failed(self, outcome: Outcome, why: str) -> None:
        """The stop under way failed and the patrol carries on (the robot is at rest:
        path_mission.py): say so and move on to the next stop, with no dwell, since the
        robot never got there. A whole round of stops failed in a row ends it."""
        round_number, index = self._legs[self._leg]
        place = self._stop().place
        self._reached(outcome, why)
        self._failed_in_a_row += 1
        self._leg += 1
        if self._failed_in_a_row >= len(self.patrol.stops):
            self._problem = (f"every stop failed, {self._failed_in_a_row} in a row; the last, "
                             f"{place}: {why}")  # fmt: skip
            return
        self._notify(f"patrol {self.name}: round {round_number}, stop {index + 1} ({place}) "
                     f"failed: {why}; going on to the next stop")  # fmt: skip

    def _charging_detour(self) -> ChargingDetour | None:
        """To the dock, if the battery is low; back to here after, if the next stop is a
        taught route, which starts where the stop before it ended."""
        recharge = self._recharge
        battery = recharge.low() if recharge is not None else None
        if recharge is None or battery is None:
            return None
        left_off = self._pose() if self._pose is not None and self._stop().route else None
        return ChargingDetour(recharge, battery, left_off, self._notify, f"patrol {self.name}")

    def next_due(self) -> float | None:
        """The end of the dwell, or when the route being driven next sends something."""
        if self._paused_at is not None or self.finished:
            return None
        if self._detour is not None:
            return self._detour.next_due()
        return self._dwell_end if self._dwell_end is not None else self._mission.next_due()

    def pause(self, now: float) -> None:
        if self._paused_at is None:
            self._paused_at = now
            if self._detour is not None:
                self._detour.pause(now)
            elif self._dwell_end is None:
                self._mission.pause(now)

    def resume(self, now: float) -> None:
        """Carry on: the route from where it paused, or the rest of the dwell."""
        if self._paused_at is None:
            return
        if self._detour is not None:
            self._detour.resume(now)
        elif self._dwell_end is not None:
            self._dwell_end += now - self._paused_at
        else:
            self._mission.resume(now)
        self._paused_at = None

    @property
    def finished(self) -> bool:
        """True once the last dwell of the last round is over."""
        return self._leg == len(self._legs)

    @property
    def problem(self) -> str | None:
        if self._problem is not None:
            return self._problem
        if self._detour is not None:
            return self._detour.problem
        return None if self.finished else self._mission.problem

    @property
    def time_left(self) -> float:
        """An estimate: what is left of this leg, then the taught durations and dwells.
        Legs to rooms count only once they have started: their plan is made then."""
        if self.finished:
            return 0.0
        at = self._paused_at if self._paused_at is not None else self._now
        if self._dwell_end is None:
            left = _mission_time_left(self._mission, at or 0.0) + self._stop().dwell
        else:
            left = max(self._dwell_end - (at or 0.0), 0.0)
        for _, index in self._legs[self._leg + 1 :]:
            stop = self.patrol.stops[index]
            taught = self._routes[stop.route].duration if stop.route is not None else 0.0
            left += taught + stop.dwell
        return left

    @property
    def progress(self) -> Progress:
        """The round and stop, the time left (frozen while paused), and the stop's own
        progress as the detail until it has arrived; during a detour to the dock, the
        detour's, with no time left: how long a charge takes is not known."""
        name = f"patrol {self.name}"
        if self.finished:
            return Progress(name, f"done, {self.patrol.rounds} rounds")
        round_number, index = self._legs[self._leg]
        rounds, place = f"round {round_number}/{self.patrol.rounds}", self._stop().place
        if self._detour is not None:
            before = f"{rounds}, before stop {index + 1} ({place})"
            return Progress(name, before, detail=self._detour.progress)
        of = f"stop {index + 1}/{len(self.patrol.stops)}"
        # Narrow, the round only if there is more than one, and the place not at all: the
        # leg's own progress names it, and the map shows it.
        brief = of if self.patrol.rounds == 1 else f"{rounds}, {of}"
        detail = self._mission.progress if self._dwell_end is None else None
        return Progress(name, f"{rounds}, {of} ({place})", eta_s=self.time_left, detail=detail,
                        brief=brief)  # fmt: skip

    def _stop(self) -> Stop:
        return self.patrol.stops[self._legs[self._leg][1]]


def _mission_time_left(mission: Mission, now: float) -> float:
    if isinstance(mission, RouteReplay):
        return max(mission.route.duration - mission.elapsed, 0.0)
    if isinstance(mission, PathMission):
        return mission.executor.remaining_time(now)
    return 0.0


class _Idle:
    """The leg of a stop that could not start: nothing to do, and never finished."""

    name = "idle"
    problem = None
    finished = False
    progress = Progress(name, "")

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        return []

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        pass

    def resume(self, now: float) -> None:
        pass
