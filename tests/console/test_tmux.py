"""The real console in tmux, driven as a user would: keys in, capture-pane out.

Needs tmux; skipped without it. The simulator runs in its own process and logs its true
pose, which is how the distances below are measured.
"""

from __future__ import annotations

import itertools
import re
import shutil
import time

import pytest

from tests.console.support import SimulatedRobot, Tmux, console_command, pose_at, settled

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")


@pytest.fixture
def session(tmp_path):
    robot = SimulatedRobot(tmp_path)
    try:
        tmux = Tmux(console_command(robot.path))
        try:
            yield robot, tmux
        finally:
            tmux.kill()
    finally:
        robot.close()


def test_hold_release_and_an_ssh_drop_in_tmux(session):
    robot, tmux = session
    screen = tmux.wait_for("connected to")
    assert "LINK LOST" not in screen

    last_key = tmux.hold("Up", 2.0)
    robot.wait_until_still()
    samples = robot.samples()
    start_x = samples[0].x
    travelled = samples[-1].x - start_x
    assert 0.6 <= travelled <= 1.0
    # The screen shows the pose (odometry) that matches the robot's.
    shown = float(re.search(r"X=(-?[0-9.]+)", tmux.wait_for("X=")).group(1))
    assert shown == pytest.approx(samples[-1].x, abs=0.01)
    # Released: braking starts within 0.7 s of the last repeat.
    speeds = [(b.time, (b.x - a.x) / (b.time - a.time)) for a, b in itertools.pairwise(samples)]
    braking = [t for t, v in speeds if t > last_key and v < 0.38]
    assert braking and braking[0] - last_key <= 0.7
    print(f"held 2 s: {travelled:.3f} m; braking {braking[0] - last_key:.3f} s after the last key")

    tmux.hold("Up", 3.0)  # cruising again
    killed_at = time.monotonic()
    tmux.kill()  # the SSH connection drops, tmux and all
    robot.wait_until_still()
    samples = robot.samples()
    run_on = settled(samples, killed_at).x - pose_at(samples, killed_at).x
    print(f"run-on after tmux was killed: {run_on:.3f} m")
    assert run_on <= 0.3
