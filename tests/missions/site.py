"""A simulated board in the example care home, its control loop, on a virtual clock."""

from __future__ import annotations

from pathlib import Path

from giraff_console.link import BoardLink
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.mission import MissionEnd
from giraff_console.robot.odometry import Pose
from giraff_console.robot.teleop import Teleop
from giraff_console.runtime.sim_site import SimulatedSite
from tests.listening import notes_into

EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"
PLAN = load_floorplan(EXAMPLE)
TICK = 0.05
LIMITS = MotionLimits()


class Site:
    """A simulated board in the care home, its control loop, and a `go` run on them."""

    def __init__(self, navigator: Navigator, imperfect: int | None = None,
                 board: str = "") -> None:  # fmt: skip
        """`board`: more options for the simulator's URL, e.g. `&firmware=later`."""
        options = "clock=virtual" + (f"&imperfect=1&seed={imperfect}" if imperfect else "") + board
        self.link = BoardLink.open(f"giraff-sim://?{options}")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.navigator = navigator
        start = navigator.start_pose
        self.site = SimulatedSite(self.board, PLAN, start)
        self.control = ControlLoop(lambda: self.link, teleop=Teleop(),
                                   deadman=Deadman(self.clock), clock=self.clock)  # fmt: skip
        # As the front ends do: the simulated robot's casters are the simulator's to say.
        self.control.localisation.casters_turn_up_to(self.site.caster_drift)
        # The rig puts the simulated robot on its dock and says so (robot/localisation.py).
        self.control.place(start, PoseBasis.GIVEN)
        self.notes: list[str] = []
        self.control.subscribe(notes_into(self.notes))
        # How each mission ended (its words for the operator: `ended`).
        self.ends: list[MissionEnd] = []
        self.control.tick()

    def go(self, room: str) -> GoTo:
        return self.start(GoTo(self.navigator, room, self.pose, tick=TICK, limits=LIMITS,
                               sense=self.sense))  # fmt: skip

    def start(self, mission):
        """Let the control loop run `mission`; its end goes to `ended`."""
        self.control.run_mission(mission, self.ends.append)
        return mission

    @property
    def ended(self) -> list[str]:
        """What the loop said of each mission's end, as the operator reads it."""
        return [end.why for end in self.ends]

    def pose(self) -> Pose:
        """Where the odometry has the robot: what missions steer by."""
        return self.control.odometry.pose

    @property
    def sense(self):
        return self.site.range_finder.readings

    def run(self, seconds: float, until_ended: bool = True) -> None:
        """Tick at 20 Hz for `seconds` of virtual time, or until the mission ends."""
        end = self.clock.now() + seconds
        while self.clock.now() < end and not (until_ended and self.ended):
            self.control.tick()
            self.clock.advance(TICK)

    def true_pose(self) -> Pose:
        return self.site.true_pose()
