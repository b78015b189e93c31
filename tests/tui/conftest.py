"""The console on the simulator and a virtual clock, with the control loop stepped by hand."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest
from textual import events

from giraff_console.link import BoardLink
from giraff_console.robot.deadman import Intent
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.settings import Settings
from giraff_console.sim.battery import Battery
from giraff_console.tui.app import GiraffConsole
from giraff_console.tui.messages import CameraPictureUpdated

TICK = 0.05
EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"
# One open room, the robot at the origin facing +x where the simulator starts it: the
# console with no building of its own to show.
OPEN_FLOOR = Path(__file__).resolve().parents[1] / "console/open-floor.yaml"


class Rig:
    """The app on the robot the console runs on, built by the composition root
    (runtime/robot.py) on the simulator and its virtual clock; its control loop is not
    started but ticked here, by hand."""

    def __init__(self, camera: bool = False, recordings: Path | None = None,
                 floorplan: Path | None = None, firmware: str | None = None,
                 battery: float | None = None) -> None:  # fmt: skip
        """`floorplan`: the building shown on the map (None: an open floor, no map);
        `recordings`: where sessions go, and routes beside them; `firmware`, `battery`:
        the simulated board's (later firmware has a battery; its charge, 0 to 1)."""
        options = RobotOptions(
            floorplan=floorplan or OPEN_FLOOR,
            recordings=recordings,
            routes=recordings.parent / "routes" if recordings is not None else None,
            screen=True,
            # On the simulator's virtual clock, which the rig moves on itself.
            sim_speed=math.inf,
            firmware=firmware,
            # The markers find the robot through the camera, which only a camera rig
            # shows (`show_camera`); without it, dead reckoning alone, as before.
            landmarks=camera,
        )
        settings = Settings()
        robot = self.parts = Robot(options, settings, EXAMPLE)
        self.clock = robot.control.clock
        assert robot.site is not None
        self.board = robot.site.board
        if battery is not None:
            self.board.battery = Battery(battery, self.clock.now())
        self.control = robot.control
        # The link the loop will use, opened now, so that a test can watch its traffic
        # from the first exchange; a reconnection opens another, as on the robot.
        connect = robot.control.connect
        self.link: BoardLink = connect()
        links = [self.link]
        self.control.connect = lambda: links.pop() if links else connect()
        # Counted, so that a key can be waited for until it has reached the loop.
        self.presses = 0
        press = self.control.press

        def counted_press(intent: Intent) -> None:
            self.presses += 1
            press(intent)

        self.control.press = counted_press
        self.navigator = robot.navigator if floorplan is not None else None
        self.camera = robot.camera if camera else None
        if self.camera is not None:
            # Frames are stamped on the virtual clock, like the log, so that they line up.
            self.camera.source.clock = self.clock.now
        self.sessions = robot.sessions if recordings is not None else None
        self.routes = robot.routes if recordings is not None else None
        self.robot = robot.service
        plan = robot.plan if floorplan is not None else None
        self.app = GiraffConsole(
            robot.service,
            clock=self.clock,
            plan=plan,
            walls=robot.navigator.walls if plan is not None else None,
            stop=robot.stop,
            simulator=True,
            camera=self.camera,
            undock_distance=settings.teleop.undock_distance,
            battery_low=settings.battery.low,
            timestamp=lambda: f"{self.clock.now():.2f}s",
            cursor_blink=False,
        )

    def __enter__(self) -> Rig:
        return self

    def __exit__(self, *exc: object) -> None:
        """The robot closed: its service's workers, its camera, its link."""
        self.parts.close()

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
def rig() -> Iterator[Rig]:
    with Rig() as rig:
        yield rig


@pytest.fixture
def camera_rig() -> Iterator[Rig]:
    with Rig(camera=True) as rig:
        yield rig


@pytest.fixture
def care_home_rig() -> Iterator[Rig]:
    with Rig(floorplan=EXAMPLE) as rig:
        yield rig


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
