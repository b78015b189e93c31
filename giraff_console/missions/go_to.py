"""`go <room>`: to a room of the floor plan, by the route the planner finds (§2.5-§2.7).

The thesis stops at planning; this is the step it calls "getting there" (§2.7): the
route from A* over the rooms and D* Lite across them (§2.6.2, §2.6.4) is driven as a
path mission (path_mission.py). When an obstacle blocks the way ahead and the room's
grid has no way round, the room graph routes round it through other doors; a door the
operator closes on the route does the same.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from giraff_console.missions.lookout import Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.path_mission import Course, PathMission
from giraff_console.missions.progress_watch import Patience
from giraff_console.motion.path import wrap
from giraff_console.motion.shaping import TurnLimits
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.room_graph import PlanningError
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.robot.odometry import Pose

# What `go --json` prints, in order: the same keys however the go ended, refused too.
GO_JSON_KEYS = (
    "arrived",
    "outcome",
    "room",
    "why",
    "detail",
    "pose_estimate",
    "pose_true",
    "error_m",
    "heading_error_deg",
    "duration_s",
    "time_optimal_s",
    "stops",
    "max_jerk",
    "gear_jumps",
    "replans",
    "contacts",
    "since_fix_m",
)


@dataclass
class GoReport:
    """How a `go` went, as `giraff-console go --json` prints it."""

    room: str
    end: MissionEnd
    pose_estimate: Pose
    goal: tuple[float, float]
    goal_heading: float | None  # radians; None: the room asks for none
    duration_s: float
    time_optimal_s: float
    stops: list[float] = field(default_factory=list)
    max_jerk: float = 0.0
    gear_jumps: int = 0
    replans: int = 0
    contacts: int = 0
    # Metres driven on the odometry alone since a marker (or the placing) last said
    # where the robot was, as it ended; None without an estimate.
    since_fix_m: float | None = None
    # Where the simulated robot really was as it ended (never the console's to know,
    # only to report); None on a real robot.
    pose_true: Pose | None = None

    @property
    def arrived(self) -> bool:
        """Arrived, and the pose confirmed: the only arrival a mission claims (issue 25)."""
        return self.end.outcome is Outcome.ARRIVED

    def as_json(self) -> dict:
        """The report; errors are measured from the true pose when the simulator gives
        one, else from the estimate."""
        pose_true = self.pose_true
        measured = pose_true or self.pose_estimate
        error = math.dist((measured.x, measured.y), self.goal)
        heading_error = 0.0
        if self.goal_heading is not None:
            heading_error = math.degrees(abs(wrap(measured.heading - self.goal_heading)))
        data = {
            "arrived": self.arrived,
            "outcome": self.end.outcome.value,
            "room": self.room,
            "why": self.end.why,
            "detail": self.end.detail,
            "pose_estimate": _pose_list(self.pose_estimate),
            "pose_true": _pose_list(pose_true) if pose_true is not None else None,
            "error_m": round(error, 4),
            "heading_error_deg": round(heading_error, 3),
            "duration_s": round(self.duration_s, 3),
            "time_optimal_s": round(self.time_optimal_s, 3),
            "stops": [round(t, 3) for t in self.stops],
            "max_jerk": round(self.max_jerk, 3),
            "gear_jumps": self.gear_jumps,
            "replans": self.replans,
            "contacts": self.contacts,
            "since_fix_m": None if self.since_fix_m is None else round(self.since_fix_m, 3),
        }
        return data


def _pose_list(pose: Pose) -> list[float]:
    return [round(pose.x, 4), round(pose.y, 4), round(math.degrees(pose.heading) % 360, 3)]


class GoTo(PathMission):
    """A Mission that takes the robot to a room of the floor plan."""

    def __init__(
        self,
        navigator: Navigator,
        room: str,
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
        self.room = room
        self.name = f"go {room}"
        self.retry = f"go {room}"
        super().__init__(navigator, pose, tick=tick, limits=limits, turn_limits=turn_limits,
                         sense=sense, notify=notify, patience=patience,
                         estimate=estimate, touched=touched, markers=markers)  # fmt: skip

    def _course(self, pose: Pose) -> Course:
        assert self.navigator is not None
        try:
            planned = self.navigator.go(self.room, pose, afresh=not self.replanning)
        except PlanningError as error:
            if self.replanning:
                raise PlanningError(f"no way to {self.room} any more: {error}") from None
            raise
        return Course(planned.path, planned.goal_heading, planned.doorways,
                      tuple(planned.route.doors), planned)  # fmt: skip

    def report(self, end: MissionEnd, pose_true: Pose | None = None) -> GoReport:
        """How it went, once the loop has ended the mission (`end`); `pose_true`: where
        the simulated robot really is."""
        assert self.navigator is not None
        goal = self.navigator.plan.rooms[self.room]
        heading = None if goal.heading is None else math.radians(goal.heading)
        return go_report(self, self.room, goal.at, heading, end, pose_true)


def go_report(mission: PathMission, goal_name: str, goal: tuple[float, float],
              goal_heading: float | None, end: MissionEnd,
              pose_true: Pose | None = None) -> GoReport:  # fmt: skip
    """How a path mission to `goal` went, once the loop has ended it (`end`)."""
    start = mission.started_at if mission.started_at is not None else mission.now
    finish = mission.ended_at if mission.ended_at is not None else mission.now
    trace = mission.merged_trace()
    return GoReport(
        room=goal_name,
        end=end,
        pose_estimate=mission.pose_now(),
        goal=goal,
        goal_heading=goal_heading,
        duration_s=finish - start,
        time_optimal_s=mission.time_optimal,
        stops=[t - start for t in trace.stops],
        max_jerk=trace.max_jerk(),
        gear_jumps=trace.gear_jumps,
        replans=mission.replans,
        contacts=mission.contacts,
        since_fix_m=mission.since_fix_m(),
        pose_true=pose_true,
    )
