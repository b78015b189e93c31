"""The console on the simulator and a virtual clock, with the control loop stepped by hand."""

from __future__ import annotations

from pathlib import Path

import pytest
from textual import events

from giraff_console.link import BoardLink
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.teleop import Teleop
from giraff_console.runtime.camera import camera_feed, find_the_robot
from giraff_console.runtime.sim_site import SimulatedSite
from giraff_console.service.robot_service import RobotService
from giraff_console.sim.drive import TruePose
from giraff_console.tui.app import GiraffConsole
from giraff_console.tui.messages import CameraPictureUpdated

TICK = 0.05
EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"


class Rig:
    """The app, its control loop and the simulated board behind it."""

    def __init__(self, camera: bool = False, recordings: Path | None = None,
                 floorplan: Path | None = None, board: str = "") -> None:  # fmt: skip
        """`board`: more options for the simulator's URL, e.g. `&firmware=later`."""
        self.link = BoardLink.open(f"giraff-sim://?clock=virtual{board}")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.control = ControlLoop(
            lambda: self.link, teleop=Teleop(), deadman=Deadman(self.clock), clock=self.clock
        )
        # Counted, so that a key can be waited for until it has reached the loop.
        self.presses = 0
        press = self.control.press

        def counted_press(intent: Intent) -> None:
            self.presses += 1
            press(intent)

        self.control.press = counted_press
        self.navigator = None
        plan = None
        if floorplan is not None:
            plan = load_floorplan(floorplan)
            self.navigator = Navigator(plan, walls_of(plan))
            start = self.navigator.start_pose
            assert start is not None
            self.control.place(start, PoseBasis.GIVEN)
            self.board.place(TruePose(start.x, start.y, start.heading))
        else:
            # The simulated robot stands where it starts, as `giraff-console --sim`
            # has it (runtime/robot.py): a pose given, not assumed.
            self.control.place(self.control.pose, PoseBasis.GIVEN)
        self.camera = None
        if camera and plan is not None:
            # The camera sees the plan's building and its markers, which the detector
            # finds and the localisation is fed, as `giraff-console --sim` does.
            site = SimulatedSite(self.board, plan, self.navigator.start_pose)
            self.camera = camera_feed(None, self.link.port, world=site.world,
                                      surroundings=site.surroundings,
                                      landmarks=plan.landmarks, clock=self.clock)  # fmt: skip
            find_the_robot(self.control, self.camera, plan)
        elif camera:
            self.camera = camera_feed(None, self.link.port)
        if self.camera is not None:
            # Frames are stamped on the virtual clock, like the log, so that they line up.
            self.camera.source.clock = self.clock.now
        self.sessions = self.routes = None
        drives = DriveSetup.on_loop(self.control, self.navigator)
        if recordings is not None:
            setup = RecordingSetup(port="giraff-sim://?clock=virtual")
            self.sessions = Sessions(self.control, self.camera, recordings, setup, print)
            routes = recordings.parent / "routes"
            self.routes = RouteBook(self.control, self.sessions, routes, print, drives)
        self.robot = RobotService(self.control, drives, routes=self.routes,
                                  sessions=self.sessions)  # fmt: skip
        self.app = GiraffConsole(
            self.robot,
            clock=self.clock,
            plan=self.navigator.plan if self.navigator is not None else None,
            walls=self.navigator.walls if self.navigator is not None else None,
            stop=self.control.stop,
            simulator=True,
            camera=self.camera,
            timestamp=lambda: f"{self.clock.now():.2f}s",
            cursor_blink=False,
        )

    async def show_camera(self, pilot) -> None:
        """One camera frame, captured and rendered as the feed's thread would."""
        picture = self.camera.picture()
        self.app.post_message(CameraPictureUpdated(picture))
        await pilot.pause()

    async def run(self, pilot, seconds: float) -> None:
        """Tick the control loop at 20 Hz for `seconds` of virtual time.

        Like the loop's own thread, it also ticks whenever a playback or a mission
        asks to be stepped between two ticks.
        """
        end = self.clock.now() + seconds
        next_tick = self.clock.now()
        while self.clock.now() < end - 1e-9:
            due = self.control.next_due()
            early = due < next_tick
            self.control.tick(early=early)
            if not early:
                next_tick += TICK
            # The app takes in this tick's telemetry and notes at this tick's time, however
            # loaded the machine: a fixed number of `asyncio.sleep(0)` is not enough when
            # Textual's real-time timers queue messages of their own in between.
            await pilot._wait_for_screen()
            self.clock.advance(max(0.0, min(next_tick, self.control.next_due(), end)
                                   - self.clock.now()))  # fmt: skip
        await pilot.pause()

    async def _press_now(self, pilot, key: str) -> None:
        """Send `key` and wait until it has reached the control loop, before time moves on."""
        presses = self.presses
        self.app._driver.send_message(events.Key(key, None))
        for _ in range(50):
            # What `pilot.pause` waits for (every widget's queue handled once), without
            # its wait for the CPU to go idle.
            await pilot._wait_for_screen()
            if self.presses > presses:
                return
        raise AssertionError(f"{key} never reached the control loop")

    async def hold(self, pilot, key: str, seconds: float) -> None:
        """Press `key`, then repeat it every 33 ms after the 0.5 s initial delay.

        The repeats go through the app's driver like real key events; waiting for the
        app to go idle after each one, as `pilot.press` does, would make tests slow.
        """
        start = self.clock.now()
        await pilot.press(key)
        next_press, next_tick = start + 0.5, start
        while self.clock.now() < start + seconds:
            if self.clock.now() >= next_tick:
                self.control.tick()
                next_tick += TICK
            if self.clock.now() >= next_press:
                await self._press_now(pilot, key)
                next_press += 0.033
            self.clock.advance(max(0.0, min(next_tick, next_press) - self.clock.now()))
        await pilot.pause()


@pytest.fixture
def rig() -> Rig:
    return Rig()


@pytest.fixture
def camera_rig() -> Rig:
    return Rig(camera=True)


@pytest.fixture
def care_home_rig() -> Rig:
    return Rig(floorplan=EXAMPLE)


def record_demo_session(root: Path) -> Path:
    """Three seconds of driving a curve, with the camera, recorded as `root/demo`."""
    rig = Rig(camera=True, recordings=root)
    assert rig.sessions is not None and rig.camera is not None
    rig.sessions.start_recording()
    for tick in range(80):
        if tick < 40:
            rig.control.press(Intent.FORWARD_LEFT)
        rig.control.tick()
        if tick % 2 == 0:
            rig.camera.picture()
        rig.clock.advance(TICK)
    path = rig.sessions.stop_recording()
    assert path is not None
    return path.rename(root / "demo")
