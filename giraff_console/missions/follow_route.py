"""A taught route followed closed-loop: along the path it was driven, not its commands.

§2.6.1's recorded route replays "the recorded actions", and route_replay.py does that:
open-loop, so the robot drifts a little more each time and cannot steer round anything.
Teaching also keeps the path the odometry saw (routes/README.md, `path`); followed as a
path mission (path_mission.py), the route is shaped into clothoid turns, driven with a
jerk-limited profile and steered back onto it from the odometry, and the range finder's
obstacles stop it. A taught path is the one way the operator chose, so there is no way
round: an obstacle on it ends the mission with the reason, where `go` would replan.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from itertools import pairwise

from giraff_console.missions.lookout import LOOKOUT_M, Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.path_mission import Course, PathMission
from giraff_console.missions.progress_watch import Patience
from giraff_console.missions.route import Route
from giraff_console.motion.shaping import TurnLimits
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.room_graph import PlanningError
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose

# The robot must stand this close to where the route starts (else: go there first).
START_REACH_M = 1.0
# Path samples closer than this to the one kept before are dropped.
SAMPLE_SPACING_M = 0.05


class FollowRoute(PathMission):
    """A Mission that drives a taught route's path, steering from the odometry."""

    def __init__(
        self,
        route: Route,
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
        if not route.path:
            raise PlanningError(f"route {route.name} has no path to follow (taught before "
                                "paths were kept?); replay-route drives its commands")  # fmt: skip
        self.route = route
        self.name = f"follow {route.name}"
        self.retry = f"follow-route {route.name}"
        self._points = _spaced([(sample.x, sample.y) for sample in route.path])
        self._goal_heading = route.path[-1].heading
        self._passed = 0  # path points behind the robot
        super().__init__(navigator, pose, tick=tick, limits=limits, turn_limits=turn_limits,
                         sense=sense, notify=notify, patience=patience,
                         estimate=estimate, touched=touched, markers=markers)  # fmt: skip

    def _course(self, pose: Pose) -> Course:
        here = (pose.x, pose.y)
        points = self._points
        if self._passed == 0:
            away = math.dist(here, points[0])
            if away > START_REACH_M and not self.replanning:
                raise PlanningError(
                    f"the robot is {away:.1f} m from where route {self.route.name} starts; "
                    f"drive it there first (within {START_REACH_M} m)"
                )
        # Carry on from the point nearest the robot, never going back along the path.
        nearest = min(range(self._passed, len(points)),
                      key=lambda i: math.dist(here, points[i]))  # fmt: skip
        self._passed = nearest
        rest = [here, *points[nearest + 1 :]] if nearest + 1 < len(points) else [here, points[-1]]
        self._check_clear(rest)
        return Course(rest, self._goal_heading)

    def _check_clear(self, points: list[tuple[float, float]]) -> None:
        """PlanningError if what is known of the grid blocks the path ahead."""
        legs = self.navigator.planner.legs if self.navigator is not None else None
        if legs is None or self.navigator is None or not self.navigator.state.obstacles:
            return
        travelled = 0.0
        for a, b in pairwise(points):
            if travelled > LOOKOUT_M:
                return
            if not legs.clear(a, b):
                raise PlanningError(
                    f"the taught path of {self.route.name} is blocked near "
                    f"({b[0]:.1f}, {b[1]:.1f}); a taught route has no way round"
                )
            travelled += math.dist(a, b)


def _spaced(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The points without those closer than SAMPLE_SPACING_M to the last one kept; the
    end is always kept."""
    kept = [points[0]]
    for point in points[1:]:
        if math.dist(point, kept[-1]) >= SAMPLE_SPACING_M:
            kept.append(point)
    if kept[-1] != points[-1]:
        kept.append(points[-1])
    return kept
