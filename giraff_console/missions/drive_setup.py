"""What every mission that drives by the floor plan is built with, gathered once.

`go ROOM`, `go dock`, a followed route and a patrol's way back to where it left off all
need the same things: the plan's navigator, where the robot is, the loop's tick, the
motion limits, the range finder, somewhere to say what happens, how long to wait on no
progress and the pose estimate. Whoever owns the control loop (the console, `go`,
`patrol`, the route book) gathers them into one DriveSetup, and every such mission is
built here, so that the front ends build nothing themselves (issue 15).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import KW_ONLY, dataclass

from giraff_console.missions.docking import GoToPose, go_mission
from giraff_console.missions.follow_route import FollowRoute
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.lookout import Sense
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.progress_watch import Patience
from giraff_console.missions.route import Route
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import Arrival
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose


@dataclass(frozen=True)
class DriveSetup:
    """The parts a driving mission is built from. `navigator` is None without a floor
    plan: routes can then be followed, but no room gone to. `sense` is
    None on a real robot, which has no range finder the console reads."""

    navigator: Navigator | None
    pose: Callable[[], Pose]
    tick: float
    _: KW_ONLY
    limits: MotionLimits | None = None
    sense: Sense | None = None
    notify: Callable[[str], None] = lambda text: None
    patience: Patience | None = None
    estimate: Callable[[], Estimate] | None = None
    touched: Callable[[], None] = lambda: None
    markers: Callable[[], Mapping[int, Pose]] | None = None

    @classmethod
    def on_loop(cls, control: ControlLoop, navigator: Navigator | None, *,
                limits: MotionLimits | None = None, sense: Sense | None = None,
                patience: Patience | None = None,
                notify: Callable[[str], None] | None = None) -> DriveSetup:  # fmt: skip
        """For missions the loop `control` runs: its pose, tick and estimate, and, unless
        `notify`, its notes, which reach whoever listens to the loop when they are made."""
        return cls(navigator, lambda: control.pose, control.period, limits=limits,
                   sense=sense, notify=notify or control.note, patience=patience,
                   estimate=control.estimate, touched=control.localisation.touched,
                   markers=lambda: control.localisation.markers)  # fmt: skip

    def go(self, room: str) -> GoTo | GoToPose:
        """To a room of the plan, or onto the dock (`dock`); PlanningError if there is no
        floor plan or no way."""
        return go_mission(self._plan(), room, self.pose, tick=self.tick, limits=self.limits,
                          sense=self.sense, notify=self.notify, patience=self.patience,
                          estimate=self.estimate,
                          touched=self.touched, markers=self.markers)  # fmt: skip

    def arrive(self, goal: str, arrival: Arrival) -> GoToPose:
        """To a point of the plan named `goal`, arriving as `arrival` says; PlanningError
        if there is no floor plan or no way."""
        return GoToPose(self._plan(), goal, arrival, self.pose, tick=self.tick,
                        limits=self.limits, sense=self.sense, notify=self.notify,
                        patience=self.patience, estimate=self.estimate,
                        touched=self.touched, markers=self.markers)  # fmt: skip

    def follow(self, route: Route) -> FollowRoute:
        """Along a taught route's path, closed loop; PlanningError if the route has no
        path or the robot is too far from its start."""
        return FollowRoute(route, self.navigator, self.pose, tick=self.tick,
                           limits=self.limits, sense=self.sense, notify=self.notify,
                           patience=self.patience, estimate=self.estimate,
                           touched=self.touched, markers=self.markers)  # fmt: skip

    def _plan(self) -> Navigator:
        if self.navigator is None:
            raise PlanningError("there is no floor plan to find the way by")
        return self.navigator
