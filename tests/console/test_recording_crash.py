"""A recording survives the console being killed outright (kill -9, a power loss)."""

from __future__ import annotations

import os
import signal
import time

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import read_log
from giraff_console.recording.playback import Playback, frame_times
from giraff_console.recording.recorded_video import RecordedVideo
from giraff_console.robot.replay import Replayer
from tests.console.support import SimulatedRobot, drain, hold_up, spawn_console


@pytest.fixture
def robot(tmp_path):
    robot = SimulatedRobot(tmp_path)
    yield robot
    robot.close()


def test_a_session_killed_mid_recording_plays_up_to_its_last_complete_line(robot, tmp_path):
    recordings = tmp_path / "recordings"
    pid, master = spawn_console(robot.path, "--recordings", str(recordings))
    try:
        drain(master, 3.0)
        os.write(master, b"r")
        drain(master, 0.5)
        hold_up(master, 2.0)
        os.kill(pid, signal.SIGKILL)  # no handler runs, nothing is closed
        os.waitpid(pid, 0)
    finally:
        os.close(master)
    robot.wait_until_still()

    (session,) = recordings.iterdir()
    log = read_log(session / "control.log")
    assert len(log.entries) > 30  # 20 polls a second for over two seconds
    # At most the line being written when the process died is lost.
    assert all("incomplete last line" in str(p) for p in log.problems)
    assert len(log.problems) <= 1

    clock = VirtualClock()
    replayer = Replayer(Playback(session.name, log, clock.now()))
    shown = []
    while not replayer.playback.finished(clock.now()):
        replayer.advance(clock.now(), shown.append)
        clock.advance(0.05)
    assert len(shown) == len(log.entries)
    assert replayer.pose.x > 0.3  # the drive is in it

    # Each frame's time was on disk as it was taken; the MP4 itself was never finished,
    # and an MP4 without its index cannot be read: playback shows no video, and no error.
    times = frame_times(session, log)
    assert len(times) > 10
    video = RecordedVideo(session / "camera.mp4", times, lambda: log.duration, time.monotonic)
    video.open(800, 600)
    assert video.read() is None
    video.close()
