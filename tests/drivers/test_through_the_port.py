"""The two driver clients (clients.py) through the daemon's virtual port (issue 27).

The robot is built by the composition root as `serve --sim --virtual-port` builds it
(runtime.Robot: the simulator on its clock at real time, the control loop on its own
thread, the port a client of the service), on an open floor. The clients talk to the
port's pseudo-terminal as they would to a board. Issue 27's "done when", through the
port: each starts with no error reply, reads the battery level, drives 1 m and turns 90
degrees on the spot with its own odometry within 1 cm and 0.5 degrees of the true pose,
and a left curve turns left. And a client killed while it drives leaves the robot
stopped within the runaway limit.
"""

from __future__ import annotations

import math
import os
import select
import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from giraff_console.robot.odometry import Pose
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service.events import Controls
from giraff_console.service.virtual_port import PROGRAM
from giraff_console.settings import Settings
from giraff_console.sim.firmware import FIRMWARES
from tests.drivers.clients import DriverClient, Ros1LikeClient, Ros2LikeClient
from tests.drivers.kill import driving_client, went_on
from tests.drivers.wire import RawPort

pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[2]
OPEN_FLOOR = ROOT / "tests/console/open-floor.yaml"
WHEEL_BASE_M = 0.499  # the simulator's
POSITION_TOLERANCE_M = 0.01
HEADING_TOLERANCE_DEG = 0.5
RUNAWAY_M = 0.3  # design.md, "Safety rules"
KILL_TIMEOUT_S = 10.0


@pytest.fixture
def robot() -> Iterator[Callable[[str], Robot]]:
    """Starts the robot with its virtual port, on the firmware asked for."""
    started: list[Robot] = []

    def start(firmware: str) -> Robot:
        options = RobotOptions(floorplan=OPEN_FLOOR, firmware=firmware, landmarks=False,
                               virtual_port=True)  # fmt: skip
        robot = Robot(options, Settings(), OPEN_FLOOR)
        started.append(robot)
        robot.start()
        return robot

    yield start
    for robot in started:
        robot.close()


def client_on(robot: Robot, kind: str, ports: Callable[[str], RawPort],
              firmware: str) -> DriverClient:  # fmt: skip
    assert robot.port is not None
    port = ports(robot.port.path)
    client: DriverClient
    if kind == "ros2":
        client = Ros2LikeClient(port, WHEEL_BASE_M)
        client.start()
    else:
        client = Ros1LikeClient(port, WHEEL_BASE_M, twm=FIRMWARES[firmware].twm)
        client.start()
    return client


def moved(robot: Robot, start: Pose) -> Pose:
    """The true pose now, in the frame of `start` (where the client's odometry began)."""
    now = robot.true_pose()
    assert now is not None
    dx, dy = now.x - start.x, now.y - start.y
    cos, sin = math.cos(-start.heading), math.sin(-start.heading)
    return Pose(dx * cos - dy * sin, dx * sin + dy * cos, now.heading - start.heading)


def assert_on_the_true_pose(client: DriverClient, truth: Pose, what: str) -> None:
    odometry = client.odometry
    position = math.hypot(odometry.x - truth.x, odometry.y - truth.y)
    heading = abs(math.degrees(math.remainder(odometry.heading - truth.heading, math.tau)))
    print(f"{type(client).__name__} through the port, {what}: {position * 1000:.2f} mm, "
          f"{heading:.3f} deg off the true pose")  # fmt: skip
    assert position <= POSITION_TOLERANCE_M
    assert heading <= HEADING_TOLERANCE_DEG


KINDS = [("ros2", "later"), ("ros2", "giraff-x"), ("ros1", "later"), ("ros1", "giraff-x")]


@pytest.mark.parametrize(("kind", "firmware"), KINDS)
def test_a_client_starts_on_the_port_with_no_error_reply_and_reads_the_battery(
    robot, ports, kind, firmware
):
    giraff = robot(firmware)
    client = client_on(giraff, kind, ports, firmware)
    level = client.read_battery()
    assert giraff.site is not None
    assert level == pytest.approx(giraff.site.board.battery_level, abs=1e-3)
    assert client.traffic.errors == []


@pytest.mark.parametrize(("kind", "firmware"), [("ros2", "later"), ("ros1", "later")])
def test_a_client_drives_1_m_and_turns_90_on_the_spot_through_the_port(
    robot, ports, kind, firmware
):
    giraff = robot(firmware)
    start = giraff.true_pose()
    assert start is not None
    client = client_on(giraff, kind, ports, firmware)
    holders: list[str | None] = []
    giraff.service.subscribe(lambda event: holders.append(event.holder)
                             if isinstance(event, Controls) else None)  # fmt: skip
    client.drive(1.0)
    truth = moved(giraff, start)
    assert truth.x == pytest.approx(1.0, abs=0.05)
    assert_on_the_true_pose(client, truth, "after 1 m")
    # The consoles saw who drove; its stop gave the controls back.
    assert PROGRAM in holders and giraff.service.controls().holder is None
    client.turn(90.0)
    truth = moved(giraff, start)
    assert math.degrees(truth.heading) == pytest.approx(90.0, abs=3.0)  # left
    assert_on_the_true_pose(client, truth, "after turning 90 deg on the spot")
    assert client.traffic.errors == []


@pytest.mark.parametrize(("kind", "firmware"), [("ros2", "later"), ("ros1", "giraff-x")])
def test_a_left_curve_through_the_port_turns_left(robot, ports, kind, firmware):
    giraff = robot(firmware)
    start = giraff.true_pose()
    assert start is not None
    client = client_on(giraff, kind, ports, firmware)
    if isinstance(client, Ros2LikeClient):
        client.curve(3.0, 0.3, 20.0)
    else:
        assert isinstance(client, Ros1LikeClient)
        client.curve(1.5, 0.3, 30.0)  # with twm, after its stop idiom left r = 50
    truth = moved(giraff, start)
    assert math.degrees(truth.heading) > 20.0 and truth.y > 0.1  # counter-clockwise
    assert_on_the_true_pose(client, truth, "after a left curve")
    assert client.traffic.errors == []


def test_a_client_killed_while_it_drives_leaves_the_robot_stopped_within_the_limit(robot):
    """A driver at the console's top speed, SIGKILLed: the port's clamp kept every target
    within the reach, and its hang-up stops the robot (issue 27; `bench/virtual_port.py
    --kills 30` does it thirty times)."""
    giraff = robot("later")
    assert giraff.port is not None
    command = driving_client(giraff.port.path, WHEEL_BASE_M, 0.4)
    for _ in range(2):
        program = subprocess.Popen(command, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL,
                                   text=True)  # fmt: skip
        try:
            assert program.stdout is not None
            started = select.select([program.stdout], [], [], KILL_TIMEOUT_S)[0]
            assert started and program.stdout.readline().strip() == "driving"
            time.sleep(1.5)  # at speed
        finally:
            os.kill(program.pid, signal.SIGKILL)
            program.wait(KILL_TIMEOUT_S)
        killed_at = giraff.true_pose()
        assert killed_at is not None
        travel = went_on(giraff, killed_at)
        print(f"killed at speed: {travel:.3f} m more")
        assert travel <= RUNAWAY_M
