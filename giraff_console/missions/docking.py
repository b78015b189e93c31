"""The dock: `go dock`, and the detour a patrol makes to charge (issue 13).

The robot charges standing on its dock. The console takes the dock to be where the
floor plan says the robot starts, the start room's point and heading: that is where
staff put it down, on the dock, and where the simulator charges it. Undocking backs the
robot out (A.4.9), so a docked robot faces into its dock, and docking is the reverse:
the robot lines up DOCK_RUN_M before the dock (SHORT_DOCK_RUN_M where the room is too
small for that) and drives in along the dock's heading, the last half of that at least
dead straight, square on, so that the contacts meet head on rather than at the angle a
turn would leave. A robot already on its dock stays.

A patrol that finds its battery low when it has finished a stop (its leg and its dwell)
goes to the dock, waits there until charged, backs out, and carries on. A taught route
starts where the stop before it ended, so before a route stop the robot first goes back
to where it left off.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.certainty import NEAR_ENOUGH_HEADING, trusted, unverified
from giraff_console.missions.go_to import GoReport, GoTo, go_report
from giraff_console.missions.lookout import Sense
from giraff_console.missions.names import DOCK
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.path_mission import Course, PathMission
from giraff_console.missions.progress_watch import Patience
from giraff_console.motion.shaping import TurnLimits
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import Arrival
from giraff_console.protocol.codec import Command
from giraff_console.robot.battery import Battery
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import Mission, MissionEnd, Outcome, Progress
from giraff_console.robot.odometry import Pose

# The straight run onto the dock. Its middle is pinned (motion/shaping.py), so that the
# turn into it ends half-way at the latest and the last half is straight. The robot
# lines up for it with a turn on the spot, after which the casters turn it for most of
# a metre (§3.2.1.5): the run is long enough for them to settle and the steering to
# bring the robot back onto the line before the contacts. On a 0.8 m run the imperfect
# simulator's robot came in 0.13 m to the side, again and again. Where a run this long
# is not clear, the shorter one.
DOCK_RUN_M = 1.5
SHORT_DOCK_RUN_M = 0.8
# Docked, a charger that has not started charging within this long never will: the
# robot is off its contacts.
CHARGE_START_S = 30.0
# Longer than any charge should take: an empty battery fills in about 1.5 h at the
# simulator's 60 W (327,360 W·s, wire-facts "Battery"); a charger still short of the
# level after this long is failing, and the patrol should not wait on it all night.
CHARGE_MAX_S = 4 * 3600.0
# A robot this close to its dock, and facing its way, is on it already: the simulator
# charges within these (docs/simulator.md, "The dock").
ON_DOCK_M = 0.05
ON_DOCK_DEG = 5.0


@dataclass(frozen=True)
class ChargeLevels:
    """When a patrol goes to charge (below `low` percent) and when it carries on (at
    `charged` percent or more): the settings' [battery] table."""

    low: float = 25.0
    charged: float = 90.0

    def __post_init__(self) -> None:
        if not 0 <= self.low < self.charged <= 100:
            raise ValueError("battery levels need 0 <= low < charged <= 100 (percent)")


class GoToPose(PathMission):
    """A Mission that drives to `arrival`: the dock, or where a patrol left off."""

    def __init__(self, navigator: Navigator, goal: str, arrival: Arrival,
                 pose: Callable[[], Pose], *, tick: float, limits: MotionLimits | None = None,
                 turn_limits: TurnLimits | None = None, sense: Sense | None = None,
                 notify: Callable[[str], None] = lambda text: None,
                 patience: Patience | None = None,
                 estimate: Callable[[], Estimate] | None = None,
                 touched: Callable[[], None] = lambda: None,
                 markers: Callable[[], Mapping[int, Pose]] | None = None) -> None:  # fmt: skip
        self.goal = goal
        self.arrival = arrival
        self.name = f"go {goal}"
        self.retry = f"go {goal}" if goal == DOCK else "patrol resume"
        self._there_already = self._there(pose())
        super().__init__(navigator, pose, tick=tick, limits=limits, turn_limits=turn_limits,
                         sense=sense, notify=notify, patience=patience,
                         estimate=estimate, touched=touched, markers=markers)  # fmt: skip
        if self._there_already:
            self.time_optimal = 0.0

    def _arrived_already(self, pose: Pose) -> bool:
        return self._there(pose)

    def _there(self, here: Pose) -> bool:
        arrival = self.arrival
        return (math.dist((here.x, here.y), arrival.point) <= ON_DOCK_M
                and _askew(here, arrival) <= math.radians(ON_DOCK_DEG))  # fmt: skip

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self._there_already and state is not None:
            self._there_already = False
            estimate = self._estimate() if self._estimate is not None else None
            # A robot not found yet is on its dock only by assumption: it looks first
            # (or, with nothing to look for, is not started: path_mission.py).
            if unverified(estimate, self.retry) is None and (estimate is None or not estimate.lost):
                # Out and back in again would only turn the robot round twice on the spot.
                self._started = self._now = now
                # A claimed arrival keeps the 3 degrees every stop must (certainty.py),
                # tighter than the charger's contacts need.
                sure = (
                    estimate is not None
                    and estimate.landmarks
                    and trusted(estimate)
                    and _askew(estimate.pose, self.arrival) <= NEAR_ENOUGH_HEADING
                )
                self._end(Outcome.ARRIVED if sure else Outcome.ARRIVED_UNVERIFIED,
                          "on the dock already")  # fmt: skip
                return []
        return super().step(now, state)

    def _course(self, pose: Pose) -> Course:
        assert self.navigator is not None
        planned = self.navigator.arrive(self.goal, self.arrival, pose, afresh=not self.replanning)
        points, pins = planned.path, planned.doorways
        if self.arrival.straight > 0 and len(points) >= 2:
            (ax, ay), (bx, by) = points[-2], points[-1]
            middle = ((ax + bx) / 2, (ay + by) / 2)
            points = [*points[:-1], middle, points[-1]]
            pins = pins | {middle}
        return Course(points, self.arrival.heading, pins, tuple(planned.route.doors), planned)

    def report(self, end: MissionEnd, pose_true: Pose | None = None) -> GoReport:
        """How it went, once the loop has ended the mission (`end`); `pose_true`: where
        the simulated robot really is."""
        return go_report(self, self.goal, self.arrival.point, self.arrival.heading, end,
                         pose_true)  # fmt: skip


def go_mission(navigator: Navigator, room: str, pose: Callable[[], Pose], *, tick: float,
               limits: MotionLimits | None = None, sense: Sense | None = None,
               notify: Callable[[str], None] = lambda text: None,
               patience: Patience | None = None,
               estimate: Callable[[], Estimate] | None = None,
               touched: Callable[[], None] = lambda: None,
               markers: Callable[[], Mapping[int, Pose]] | None = None,
               ) -> GoTo | GoToPose:  # fmt: skip
    """What `go ROOM` drives, for every front end: to a room of the plan, or, for
    `dock`, onto the dock square on. PlanningError if there is no way. With `estimate`
    the mission minds how well the robot knows where it is (path_mission.py)."""
    if room == DOCK:
        return GoToPose(navigator, DOCK, dock_arrival(navigator), pose, tick=tick,
                        limits=limits, sense=sense, notify=notify, patience=patience,
                        estimate=estimate, touched=touched, markers=markers)  # fmt: skip
    return GoTo(
        navigator,
        room,
        pose,
        tick=tick,
        limits=limits,
        sense=sense,
        notify=notify,
        patience=patience,
        estimate=estimate,
        touched=touched,
        markers=markers,
    )


def dock_arrival(navigator: Navigator) -> Arrival:
    """The dock as a place to arrive at; PlanningError if the plan names no start room."""
    start = navigator.start_pose
    if start is None:
        raise PlanningError("the floor plan has no start room, which is where the dock is")
    legs = navigator.planner.legs
    for run in (DOCK_RUN_M, SHORT_DOCK_RUN_M):
        arrival = Arrival((start.x, start.y), start.heading, run)
        if legs is None or legs.clear(arrival.approach, arrival.point):
            return arrival
    return arrival  # neither is clear: planning says so (route_planner.py, _ending)


def back_to(pose: Pose) -> Arrival:
    """Where a patrol left off, to go back to after charging."""
    return Arrival((pose.x, pose.y), pose.heading)


class _Phase(enum.Enum):
    DOCKING = "going to the dock"
    CHARGING = "charging"
    UNDOCKING = "backing out of the dock"
    RETURNING = "going back to where it left off"


@dataclass(frozen=True)
class Recharge:
    """What a patrol needs to charge on the way: the battery as last read, the levels,
    and the missions of the detour, made as each part starts (PlanningError if there is
    no way)."""

    battery: Callable[[], Battery | None]
    levels: ChargeLevels
    dock: Callable[[], Mission]
    undock: Callable[[], Mission]
    back_to: Callable[[Pose], Mission]

    def low(self) -> Battery | None:
        """The battery, if it is below the level to charge at."""
        battery = self.battery()
        if battery is None or battery.percent is None or battery.charging:
            return None
        return battery if battery.percent < self.levels.low else None


class ChargingDetour:
    """A Mission: to the dock, charge to the level, back out, and (with `left_off`) go
    back there. `notify` tells the operator of each step."""

    def __init__(self, recharge: Recharge, battery: Battery, left_off: Pose | None,
                 notify: Callable[[str], None], name: str) -> None:  # fmt: skip
        self.name = name
        self.recharge = recharge
        self.left_off = left_off
        self.notify = notify
        self._phase = _Phase.DOCKING
        self._charging_seen_at: float | None = None
        self._charging_since: float | None = None
        self._paused_at: float | None = None
        self.problem: str | None = None
        levels = recharge.levels
        notify(f"{name}: battery at {battery.percent:.0f} %, below {levels.low:.0f} %: going "
               f"to the dock; it carries on once charged to {levels.charged:.0f} %")  # fmt: skip
        self._mission: Mission | None = self._make(recharge.dock)

    def _make(self, make: Callable[[], Mission]) -> Mission | None:
        try:
            return make()
        except PlanningError as error:
            self.problem = f"{self._phase.value}: {error}"
            return None

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self.problem is not None or self.finished:
            return []
        if self._phase is _Phase.CHARGING:
            self._charge(now)
            return []
        mission = self._mission
        assert mission is not None
        commands = mission.step(now, state)
        if mission.problem is not None:
            self.problem = f"{self._phase.value}: {mission.problem}"
        elif mission.finished:
            self._next_phase(now)
        return commands

    def _next_phase(self, now: float) -> None:
        if self._phase is _Phase.DOCKING:
            self._phase, self._mission = _Phase.CHARGING, None
            self._charging_seen_at = self._charging_since = now
            battery = self.recharge.battery()
            percent = battery.percent if battery is not None else None
            level = f" at {percent:.0f} %" if percent is not None else ""
            self.notify(f"{self.name}: docked{level}; charging to "
                        f"{self.recharge.levels.charged:.0f} %")  # fmt: skip
        elif self._phase is _Phase.UNDOCKING and self.left_off is not None:
            self._phase = _Phase.RETURNING
            left_off = self.left_off
            self._mission = self._make(lambda: self.recharge.back_to(left_off))
        else:
            self._phase, self._mission = _Phase.RETURNING, None

    def _charge(self, now: float) -> None:
        battery = self.recharge.battery()
        charged = self.recharge.levels.charged
        if battery is not None and battery.percent is not None and battery.percent >= charged:
            self.notify(f"{self.name}: charged to {battery.percent:.0f} %; carrying on")
            self._phase = _Phase.UNDOCKING
            self._mission = self._make(self.recharge.undock)
            return
        charging = battery is not None and battery.charging
        assert self._charging_seen_at is not None and self._charging_since is not None
        if now - self._charging_since > CHARGE_MAX_S:
            level = "?" if battery is None or battery.percent is None else f"{battery.percent:.0f}"
            self.problem = (f"still at {level} % after {CHARGE_MAX_S / 3600:.0f} h on the dock, "
                            f"short of {charged:.0f} %: check the charger")  # fmt: skip
            return
        if not charging and now - self._charging_seen_at > CHARGE_START_S:
            status = "no battery reading" if battery is None else battery.status.name.lower()
            self.problem = (f"docked but not charging after {CHARGE_START_S:.0f} s ({status}): "
                            "check that the robot stands on its dock")  # fmt: skip
        elif charging:
            # Counted from when charging last stopped, not from when it docked.
            self._charging_seen_at = now

    def next_due(self) -> float | None:
        return None if self._mission is None else self._mission.next_due()

    def pause(self, now: float) -> None:
        self._paused_at = now
        if self._mission is not None:
            self._mission.pause(now)

    def resume(self, now: float) -> None:
        if self._mission is not None:
            self._mission.resume(now)
        if self._charging_seen_at is not None:
            self._charging_seen_at = now
        if self._charging_since is not None and self._paused_at is not None:
            self._charging_since += now - self._paused_at
        self._paused_at = None

    @property
    def finished(self) -> bool:
        return self._phase is _Phase.RETURNING and (self._mission is None or self._mission.finished)

    @property
    def progress(self) -> Progress:
        """The part under way's: the mission driving it, or the charge."""
        if self._phase is _Phase.CHARGING:
            battery = self.recharge.battery()
            level = "?" if battery is None or battery.percent is None else f"{battery.percent:.0f}"
            charged = self.recharge.levels.charged
            return Progress("charging at the dock", f"{level} % of {charged:.0f} %")
        mission = self._mission
        return mission.progress if mission is not None else Progress(self._phase.value, "")


def _askew(pose: Pose, arrival: Arrival) -> float:
    """How far, in radians, `pose` is turned from `arrival`'s heading."""
    return abs(math.remainder(pose.heading - arrival.heading, math.tau))
