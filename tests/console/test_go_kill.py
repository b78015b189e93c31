"""A console killed outright in the middle of a `go`: the robot stops within 0.3 m.

The board keeps executing its last move when the program driving it dies (design.md);
every move a `go` sends reaches at most 0.3 m ahead and brakes hard enough to stop
there. Here `giraff-console go` drives the simulator in another process over a real
pseudo-terminal, in real time, and is killed with SIGKILL while cruising along the
corridor; the simulator's pose log says how far the robot went on.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import CHILD_TIMEOUT
from tests.console.support import SimulatedRobot, pose_at, settled

EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"


@pytest.mark.pty
def test_killing_go_mid_route_leaves_the_robot_stopped_within_0_3_m(tmp_path):
    robot = SimulatedRobot(tmp_path, "--floorplan", str(EXAMPLE))
    # To a file: a pipe nobody reads could fill up and stall `go` mid-route.
    errors = tmp_path / "go.stderr"
    with errors.open("w") as stderr:
        go = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "go", "room-113", "--port", robot.path,
             "--floorplan", str(EXAMPLE), "--at", "dock"],
            stdout=subprocess.DEVNULL, stderr=stderr,
        )  # fmt: skip
    try:
        # Wait until the robot is cruising along the corridor, past its first turn.
        deadline = time.monotonic() + 40
        while time.monotonic() < deadline:
            samples = robot.samples()
            if samples and samples[-1].x > 4.0 and samples[-1].moving:
                break
            time.sleep(0.1)
        else:
            pytest.fail(f"the robot never got going: {errors.read_text()}")
        os.kill(go.pid, signal.SIGKILL)
        killed_at = time.monotonic()
        go.wait(timeout=CHILD_TIMEOUT)
        robot.wait_until_still()
        samples = robot.samples()
        at, rest = pose_at(samples, killed_at), settled(samples, killed_at)
        run_on = math.dist((at.x, at.y), (rest.x, rest.y))
        print(f"run-on after go was killed: {run_on:.3f} m")
        assert at.moving  # killed while driving
        assert run_on <= 0.3
    finally:
        go.kill()  # a no-op once it has been reaped
        go.wait(timeout=CHILD_TIMEOUT)
        robot.close()
