"""Playback keeps video, pose and transcript in step, at any speed and across seeks."""

from __future__ import annotations

import bisect
import csv
from pathlib import Path

import numpy as np
import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import LogEntry, LogRead, read_log
from giraff_console.recording.playback import Playback, frame_times
from giraff_console.recording.recorded_video import RecordedVideo, video_frames
from giraff_console.recording.session import VIDEO
from giraff_console.robot.replay import Replayer, replay_poses
from tests.tui.conftest import record_demo_session


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    return record_demo_session(tmp_path_factory.mktemp("recordings"))


def all_frames(path) -> list[np.ndarray]:
    return [image for _, image in video_frames(path)]


def test_video_and_pose_stay_in_step_at_any_speed_and_after_a_seek(session):
    log = read_log(session / "control.log")
    times = frame_times(session, log)
    with (session / "camera.frames.csv").open() as file:
        frame_poses = [(float(row["x"]), float(row["y"])) for row in csv.DictReader(file)]
    frames = all_frames(session / VIDEO)
    assert len(frames) == len(times) == len(frame_poses) > 10

    clock = VirtualClock()
    playback = Playback(session.name, log, clock.now())
    replayer = Replayer(playback)
    video = RecordedVideo(session / VIDEO, times,
                          lambda: playback.position(clock.now()), clock.now)  # fmt: skip
    video.open(800, 600)
    checked = 0

    def check() -> None:
        nonlocal checked
        replayer.advance(clock.now(), lambda exchange: None)
        frame = video.read()
        expected = bisect.bisect_right(times, playback.position(clock.now())) - 1
        if expected < 0:
            assert frame is None
            return
        assert np.array_equal(frame.image, frames[expected])
        # The frame's own odometry sample is the pose shown, give or take one poll.
        x, y = frame_poses[expected]
        assert replayer.pose.x == pytest.approx(x, abs=0.025)
        assert replayer.pose.y == pytest.approx(y, abs=0.025)
        checked += 1

    for speed in (1.0, 4.0, 0.25):
        playback.set_speed(clock.now(), speed)
        for _ in range(8):
            clock.advance(0.07)
            check()
    replayer.seek(clock.now(), 0.5)  # back
    check()
    replayer.seek(clock.now(), 3.0)  # and on, past frames never decoded
    check()
    video.close()
    assert checked > 20


def test_a_log_of_the_original_console_plays_to_the_pose_it_drove_to():
    log = read_log(Path(__file__).parents[1] / "recording" / "fixtures" / "original_console.txt")
    clock = VirtualClock()
    replayer = Replayer(Playback("original", log, clock.now()))
    shown = []
    while not replayer.playback.finished(clock.now()):
        replayer.advance(clock.now(), shown.append)
        clock.advance(0.05)
    assert [exchange.command for exchange in shown[:3]] == ["get bulk_data", "home", "get v"]
    assert shown[2].value == pytest.approx(0.6)
    assert replayer.pose.x == pytest.approx(0.6, abs=1e-4) and replayer.pose.y == 0.0
    assert replayer.state is not None and not replayer.state.moving


def test_a_seek_anywhere_in_a_long_session_gives_the_pose_integrated_from_the_start():
    # Four minutes of polls at 20 Hz, driving a slow curve: several odometry checkpoints.
    entries = []
    for i in range(4800):
        left, right = i * 0.0199, i * 0.0201
        reply = (f"cang:0.00000,cdis:0.00000,gvr:0.20000,tilt_angle_from_home:0.08727,"
                 f"imdl:{left:.5f},imdr:{right:.5f},cvg:0.00000,mode:128,")  # fmt: skip
        entries.append(LogEntry(i * 0.05, " ", "bulk_data", reply))
    log = LogRead(entries, [])
    expected = list(replay_poses(log))
    clock = VirtualClock()
    replayer = Replayer(Playback("long", log, clock.now(), speed=16))
    while not replayer.playback.finished(clock.now()):
        replayer.advance(clock.now(), lambda exchange: None)
        clock.advance(0.05)
    for offset in (12.34, 200.0, 0.7, 239.0, 61.0):
        replayer.seek(clock.now(), offset)
        pose = [p for p in expected if p.offset <= offset][-1]
        assert replayer.pose.x == pytest.approx(pose.x, abs=1e-9)
        assert replayer.pose.heading == pytest.approx(pose.heading, abs=1e-12)
