"""A recording survives the console being killed outright (kill -9, a power loss)."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import read_log
from giraff_console.recording.playback import Playback, frame_times
from giraff_console.recording.recorded_video import RecordedVideo, video_frames
from giraff_console.recording.session import VIDEO, read_meta
from giraff_console.robot.replay import Replayer
from tests.conftest import CHILD_TIMEOUT
from tests.console.support import (
    SimulatedRobot,
    drain,
    end_console,
    hold_up,
    spawn_console,
    wait_for_exit,
)


@pytest.fixture
def robot(tmp_path):
    robot = SimulatedRobot(tmp_path)
    yield robot
    robot.close()


def test_a_session_killed_mid_recording_plays_log_and_video_to_the_cut(robot, tmp_path):
    recordings = tmp_path / "recordings"
    pid, master = spawn_console(robot.path, "--recordings", str(recordings))
    try:
        drain(master, 3.0)
        os.write(master, b"r")
        drain(master, 0.5)
        hold_up(master, 3.0)
        killed_at = time.monotonic()  # the console's clock too: CLOCK_MONOTONIC
        os.kill(pid, signal.SIGKILL)  # no handler runs, nothing is closed
        assert wait_for_exit(pid, CHILD_TIMEOUT) is not None
    finally:
        end_console(pid, master)
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

    # Only the video segment being written is lost: OpenCV reads the video to within
    # 2 s of the kill, and playback holds its last frame to the end of the log.
    times = frame_times(session, log)
    assert len(times) > 20
    frames = list(video_frames(session / VIDEO))
    last, image = frames[-1]
    assert [number for number, _ in frames] == list(range(last + 1))
    killed = killed_at - read_meta(session)["clock_origin"]
    assert 0 < killed - times[last] <= 2.0
    video = RecordedVideo(session / VIDEO, times, lambda: log.duration, time.monotonic)
    video.open(800, 600)
    played = video.read()
    video.close()
    assert played is not None and np.array_equal(played.image, image)
