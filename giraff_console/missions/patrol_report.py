"""How a patrol went: a report for each stop as it ends, and one for the run at its end.

What `giraff-console patrol --json` prints, a line a stop and one for the patrol. They
are made where the patrol runs (RouteBook.patrol), on the loop's thread, and the robot
service tells them as events (service/events.py), so that the patrol command says the
same in the console's process and through the daemon (issue 26), and `watch` and the
consoles hear a scheduled patrol's stops too. Each report is a few dozen numbers, and
its lists of markers are the plan's at most: bounded, whatever the patrol.

A stop's goal is where `go` would measure it from: the room's point and heading (the
dock's for `dock`), or the end of the route's taught path; its errors are measured
from the true pose when the simulator gives one (GoReport), else from the estimate.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from giraff_console.missions.go_to import GoReport
from giraff_console.missions.names import DOCK
from giraff_console.missions.patrol import Patrol, PatrolRun, Stop, StopReached
from giraff_console.missions.route import Route
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.robot.odometry import Pose

# What `patrol --json` prints for each stop, in order, with or without a daemon.
STOP_JSON_KEYS = (
    "stop",
    "round",
    "room",
    "route",
    "arrived",
    "outcome",
    "why",
    "detail",
    "pose_estimate",
    "pose_true",
    "error_m",
    "heading_error_deg",
    "sigma_m",
    "sigma_heading_deg",
    "found",
    "seen",
    "rejected",
    "since_fix_m",
    "basis",
    "duration_s",
    "t_s",
    "max_jerk",
)
# And for the patrol, last. `patrol`, `outcome`, `why` and `detail` say how it ended.
PATROL_JSON_KEYS = (
    "patrol",
    "rounds",
    "stops",
    "arrived",
    "failed",
    "outcome",
    "why",
    "detail",
    "duration_s",
    "landmarks",
    "eye",
    "markers_used",
    "markers_rejected",
    "rejections",
)


@dataclass(frozen=True)
class Sight:
    """What finds the robot: whether markers do (through the eye or the camera), and
    what the marker eye has cost so far (MarkerEye.cost; None without an eye)."""

    landmarks: bool
    eye: dict[str, float | int | None] | None = None


@dataclass(frozen=True)
class StopReport:
    """How one stop of patrol `patrol` went: arrived (confirmed or not), failed and
    passed over, or the patrol ended on the way to it. `estimate` is the robot's as it
    ended; `goal` and `goal_heading` (radians) where the stop ends (None: a route
    without a taught path, or a room with no heading); `duration_s` the leg's, from the
    end of the dwell before it, `t_s` since the patrol first drove."""

    patrol: str
    round: int
    stop: int
    room: str | None
    route: str | None
    end: MissionEnd
    estimate: Estimate
    goal: tuple[float, float] | None
    goal_heading: float | None
    duration_s: float
    t_s: float
    max_jerk: float | None = None
    # Where the simulated robot really was (never the console's to know, only to
    # report); None on a real robot.
    pose_true: Pose | None = None

    @property
    def arrived(self) -> bool:
        """Arrived, and the pose confirmed: the only arrival a mission claims (issue 25)."""
        return self.end.outcome is Outcome.ARRIVED

    def as_json(self) -> dict:
        """The stop's line of `patrol --json`: STOP_JSON_KEYS."""
        estimate, goal = self.estimate, self.goal
        place = self.room if self.room is not None else str(self.route)
        measured = GoReport(
            room=place, end=self.end, pose_estimate=estimate.pose,
            goal=goal if goal is not None else (math.nan, math.nan),
            goal_heading=self.goal_heading, duration_s=self.duration_s, time_optimal_s=0.0,
            pose_true=self.pose_true,
        ).as_json()  # fmt: skip
        return {
            "stop": self.stop,
            "round": self.round,
            "room": self.room,
            "route": self.route,
            "arrived": self.arrived,
            "outcome": self.end.outcome.value,
            "why": self.end.why,
            "detail": self.end.detail,
            "pose_estimate": measured["pose_estimate"],
            "pose_true": measured["pose_true"],
            "error_m": measured["error_m"] if goal is not None else None,
            "heading_error_deg": measured["heading_error_deg"] if goal is not None else None,
            "sigma_m": round(estimate.sigma_m, 4),
            "sigma_heading_deg": round(math.degrees(estimate.sigma_heading), 3),
            "found": estimate.found,
            "seen": list(estimate.seen),
            "rejected": list(estimate.rejected),
            "since_fix_m": round(estimate.since_fix_m, 3),
            "basis": estimate.basis.value,
            "duration_s": measured["duration_s"],
            "t_s": round(self.t_s, 3),
            "max_jerk": None if self.max_jerk is None else round(self.max_jerk, 3),
        }


@dataclass(frozen=True)
class PatrolReport:
    """How a patrol run went, at its end: `stops` of every round, `arrived` of them
    confirmed by a marker, `failed` not got to; `end` as the loop ended it; the markers
    the localisation used and rejected over the run, and how many sightings it
    rejected in all."""

    patrol: str
    rounds: int
    stops: int
    arrived: int
    failed: int
    end: MissionEnd
    duration_s: float
    landmarks: bool
    eye: dict[str, float | int | None] | None = None
    markers_used: tuple[int, ...] = ()
    markers_rejected: tuple[int, ...] = ()
    rejections: int = 0

    def as_json(self) -> dict:
        """The patrol's line of `patrol --json`: PATROL_JSON_KEYS."""
        return {
            "patrol": self.patrol,
            "rounds": self.rounds,
            "stops": self.stops,
            "arrived": self.arrived,
            "failed": self.failed,
            "outcome": self.end.outcome.value,
            "why": self.end.why,
            "detail": self.end.detail,
            "duration_s": round(self.duration_s, 3),
            "landmarks": self.landmarks,
            "eye": self.eye,
            "markers_used": list(self.markers_used),
            "markers_rejected": list(self.markers_rejected),
            "rejections": self.rejections,
        }


def _no_true_pose() -> Pose | None:
    return None


def _no_sight() -> Sight:
    return Sight(landmarks=False)


@dataclass(frozen=True)
class PatrolReports:
    """Where a patrol's reports go (`stop`, `end`: on the loop's thread, so they must
    not block), and what they need that the route book does not hold: where the
    simulated robot really is, and what finds the robot."""

    stop: Callable[[StopReport], None]
    end: Callable[[PatrolReport], None]
    true_pose: Callable[[], Pose | None] = field(default=_no_true_pose)
    sight: Callable[[], Sight] = field(default=_no_sight)


class PatrolReporter:
    """One patrol run's reports, made on the loop's thread as each stop ends (the
    PatrolRun's `on_stop`) and as the run ends (the loop's `ended`). `run` is the run
    once it is made: a first stop that cannot be planned ends as the run is made."""

    def __init__(self, patrol: Patrol, routes: dict[str, Route], control: ControlLoop,
                 plan: FloorPlan | None, reports: PatrolReports) -> None:  # fmt: skip
        self.patrol = patrol
        self.routes = routes
        self.control = control
        self.plan = plan
        self.reports = reports
        self.run: PatrolRun | None = None
        self.made: list[StopReport] = []
        # When the leg under way started: the end of the last stop's dwell (None: the
        # patrol's start).
        self._leg_from: float | None = None

    def reached(self, stop: StopReached) -> None:
        """A stop's leg ended: arrived (confirmed or not), or failed and passed over."""
        why = "done" if stop.reached else f"failed: {stop.detail}"
        self._report(stop.round, stop.stop_index, MissionEnd(stop.outcome, why, stop.detail),
                     stop.max_jerk)  # fmt: skip
        dwell = self.patrol.stops[stop.stop_index - 1].dwell if stop.reached else 0.0
        self._leg_from = self.control.clock.now() + dwell

    def ended(self, end: MissionEnd) -> None:
        """The run is over: the stop it was on its way to, if any, did not arrive; then
        the patrol's report."""
        count = len(self.patrol.stops)
        total = self.patrol.rounds * count
        leg = len(self.made)
        if leg < total:
            self._report(leg // count + 1, leg % count + 1, replace(end, detail=end.why))
        started = self._started()
        localisation = self.control.localisation
        sight = self.reports.sight()
        self.reports.end(PatrolReport(
            patrol=self.patrol.name, rounds=self.patrol.rounds, stops=total,
            arrived=sum(report.arrived for report in self.made),
            failed=sum(not report.end.outcome.arrived for report in self.made),
            end=end, duration_s=self.control.clock.now() - started,
            landmarks=sight.landmarks, eye=sight.eye,
            markers_used=tuple(sorted(localisation.used)),
            markers_rejected=tuple(sorted(localisation.rejections)),
            rejections=sum(localisation.rejections.values()),
        ))  # fmt: skip

    def _started(self) -> float:
        """When the patrol first drove; now, if it never did."""
        started = self.run.started_at if self.run is not None else None
        return self.control.clock.now() if started is None else started

    def _report(self, round_number: int, index: int, end: MissionEnd,
                max_jerk: float | None = None) -> None:  # fmt: skip
        now, started = self.control.clock.now(), self._started()
        leg_from = started if self._leg_from is None else self._leg_from
        stop = self.patrol.stops[index - 1]
        goal = self._goal(stop)
        report = StopReport(
            patrol=self.patrol.name, round=round_number, stop=index, room=stop.room,
            route=stop.route, end=end, estimate=self.control.estimate(),
            goal=goal[0] if goal is not None else None,
            goal_heading=goal[1] if goal is not None else None,
            duration_s=now - leg_from, t_s=now - started, max_jerk=max_jerk,
            pose_true=self.reports.true_pose(),
        )  # fmt: skip
        self.made.append(report)
        self.reports.stop(report)

    def _goal(self, stop: Stop) -> tuple[tuple[float, float], float | None] | None:
        """Where the stop ends: the room's point and heading (radians; the dock's for
        `dock`), or the end of the route's taught path; None for a route without one."""
        if stop.room is not None:
            plan = self.plan
            if plan is None:
                return None
            start = plan.start
            room = plan.rooms.get(start if stop.room == DOCK and start else stop.room)
            if room is None:
                return None
            return room.at, None if room.heading is None else math.radians(room.heading)
        path = self.routes[str(stop.route)].path
        return ((path[-1].x, path[-1].y), path[-1].heading) if path else None
