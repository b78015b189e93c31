"""A driver killed while it drives, and how far the robot goes on (issue 27): for the
tests and for `bench/virtual_port.py --kills`."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from giraff_console.robot.odometry import Pose
from giraff_console.runtime.robot import Robot

ROOT = Path(__file__).resolve().parents[2]
# A ROS 2-like client in a process of its own: it says "driving" once it has started,
# then drives at `speed` until it is killed.
_DRIVING = """
import sys
sys.path.insert(0, {root!r})
from tests.drivers.clients import Ros2LikeClient
from tests.drivers.wire import RawPort
client = Ros2LikeClient(RawPort.open({path!r}), {wheel_base})
client.start()
print("driving", flush=True)
client.run({speed}, 0.0, lambda: False, 60.0)
"""
# Seconds the robot is given to come to rest after the kill.
REST_TIMEOUT_S = 10.0


def driving_client(path: str, wheel_base: float, speed: float) -> list[str]:
    """The command that runs a driver on the port at `path`, driving at `speed` m/s."""
    script = _DRIVING.format(root=str(ROOT), path=path, wheel_base=wheel_base, speed=speed)
    return [sys.executable, "-c", script]


def went_on(robot: Robot, start: Pose) -> float:
    """How far the robot goes from `start` until it has been still for 0.5 s (its true
    pose, which the wire never shows)."""
    deadline = time.monotonic() + REST_TIMEOUT_S
    last, still_since, farthest = start, time.monotonic(), 0.0
    while time.monotonic() - still_since < 0.5:
        if time.monotonic() > deadline:
            raise TimeoutError(f"the robot did not stop within {REST_TIMEOUT_S:g} s")
        time.sleep(0.02)
        now = robot.true_pose()
        assert now is not None
        farthest = max(farthest, math.hypot(now.x - start.x, now.y - start.y))
        if math.hypot(now.x - last.x, now.y - last.y) > 1e-4:
            still_since = time.monotonic()
        last = now
    return farthest
