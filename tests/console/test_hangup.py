"""Safety on exit: an SSH connection that drops must leave the robot stopped.

The console runs in a pseudo-terminal of its own, talking to the simulator in a third
process. Closing the terminal's master side is what sshd does when the connection
drops: the kernel sends SIGHUP to the console, which must stop the robot.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from tests.console.support import (
    SimulatedRobot,
    drain,
    hold_up,
    pose_at,
    settled,
    spawn_console,
)


@pytest.fixture
def robot(tmp_path):
    robot = SimulatedRobot(tmp_path)
    yield robot
    robot.close()


@pytest.mark.parametrize("how", ["close the terminal", "SIGTERM"])
def test_a_console_that_is_ended_mid_move_stops_the_robot_within_0_3_m(robot, how):
    pid, master = spawn_console(robot.path)
    try:
        drain(master, 3.0)  # start-up: imports, handshake, first screen
        hold_up(master, 3.0)  # cruising at 0.4 m/s by now
        assert robot.samples()[-1].moving
        dropped_at = time.monotonic()
        if how == "SIGTERM":
            os.kill(pid, signal.SIGTERM)
            drain(master, 1.0)
            os.close(master)
        else:
            os.close(master)  # the SSH connection drops: SIGHUP
        _, status = os.waitpid(pid, 0)
    except BaseException:
        os.kill(pid, 9)
        raise
    robot.wait_until_still()
    samples = robot.samples()
    run_on = settled(samples, dropped_at).x - pose_at(samples, dropped_at).x
    assert os.WIFEXITED(status)
    print(f"run-on after {how}: {run_on:.3f} m")
    assert 0 < run_on <= 0.3  # design.md
    # Less than the 0.29 m lookahead: the console commanded the stop, not just the target.
    assert run_on < 0.2
