"""Safety on exit: an SSH connection that drops must leave the robot stopped.

The console runs in a pseudo-terminal of its own, talking to the simulator in a third
process. Closing the terminal's master side is what sshd does when the connection
drops: the kernel sends SIGHUP to the console, which must stop the robot, and be gone
within 2 s, even on a loaded machine, so that it lets go of the port.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from tests.console.support import (
    SimulatedRobot,
    drain,
    end_console,
    hold_up,
    pose_at,
    settled,
    spawn_console,
    wait_for_exit,
)

# From the signal to the process being gone (issue 12); the console was started long
# before, so no allowance for its start-up is needed.
EXIT_WITHIN_S = 2.0


@pytest.fixture
def robot(tmp_path):
    robot = SimulatedRobot(tmp_path)
    yield robot
    robot.close()


@pytest.mark.parametrize("how", ["close the terminal", "SIGTERM"])
def test_a_console_that_is_ended_mid_move_stops_the_robot_and_goes(robot, how):
    pid, master = spawn_console(robot.path)
    try:
        drain(master, 3.0)  # start-up: imports, handshake, first screen
        hold_up(master, 3.0)  # cruising at 0.4 m/s by now
        assert robot.samples()[-1].moving
        dropped_at = time.monotonic()
        if how == "SIGTERM":
            os.kill(pid, signal.SIGTERM)
            status = wait_for_exit(pid, EXIT_WITHIN_S, master)
        else:
            os.close(master)  # the SSH connection drops: SIGHUP
            master = None
            status = wait_for_exit(pid, EXIT_WITHIN_S)
        gone_after = time.monotonic() - dropped_at
        assert status is not None, f"the console still ran {gone_after:.1f} s after {how}"
    finally:
        end_console(pid, master)
    robot.wait_until_still()
    samples = robot.samples()
    run_on = settled(samples, dropped_at).x - pose_at(samples, dropped_at).x
    assert os.WIFEXITED(status)
    print(f"run-on after {how}: {run_on:.3f} m; gone after {gone_after:.2f} s")
    # design.md's 0.3 m with issue 12's margin for a loaded machine. That the console
    # itself commands the stop, from its loop's thread, is tests/robot/test_emergency_stop.
    assert 0 < run_on <= 0.27
