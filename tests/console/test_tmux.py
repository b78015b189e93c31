"""The real console in tmux, driven as a user would: keys in, capture-pane out.

Needs tmux; skipped without it. The simulator runs in its own process and logs its true
pose, which is how the distances below are measured.
"""

from __future__ import annotations

import itertools
import os
import re
import shutil
import subprocess
import time

import pytest

from tests.console.support import SimulatedRobot, console_command, pose_at, settled

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")


class Tmux:
    def __init__(self, command: list[str]) -> None:
        self.socket = f"giraff-test-{os.getpid()}"
        self.tmux(
            "-f", "/dev/null", "new-session", "-d", "-x", "120", "-y", "40", " ".join(command)
        )
        self.tmux("set", "-sg", "escape-time", "10")

    def tmux(self, *args: str) -> str:
        result = subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True, text=True)
        return result.stdout

    def keys(self, *keys: str) -> None:
        self.tmux("send-keys", *keys)

    def screen(self) -> str:
        return self.tmux("capture-pane", "-p")

    def wait_for(self, text: str, timeout: float = 15.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            screen = self.screen()
            if text in screen:
                return screen
            time.sleep(0.1)
        raise AssertionError(f"{text!r} never appeared:\n{self.screen()}")

    def hold(self, key: str, seconds: float) -> float:
        """Press, then repeat every 33 ms after 0.5 s; returns the time of the last repeat."""
        start = time.monotonic()
        self.keys(key)
        next_press = start + 0.5
        last = start
        while next_press < start + seconds:
            time.sleep(max(0.0, next_press - time.monotonic()))
            self.keys(key)
            last = time.monotonic()
            next_press += 0.033
        return last

    def kill(self) -> None:
        self.tmux("kill-server")


@pytest.fixture
def session(tmp_path):
    robot = SimulatedRobot(tmp_path)
    tmux = Tmux(console_command(robot.path))
    yield robot, tmux
    tmux.kill()
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
