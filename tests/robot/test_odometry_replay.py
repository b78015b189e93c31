"""Recordings remember how the wheels were read, and play back reading them the same way."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import LogEntry, LogRead
from giraff_console.recording.playback import Playback, open_log
from giraff_console.recording.session import (
    RecordingSetup,
    SessionRecorder,
    SessionStart,
    read_meta,
)
from giraff_console.robot.deadman import Intent
from giraff_console.robot.loop_events import ExchangeTap
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.replay import Replayer, replay_poses, session_start, starting_odometry
from giraff_console.robot.wheel_odometers import COUNTS_PER_METRE, Reading
from tests.robot.test_odometry_firmware import TICK, Console
from tests.robot.test_odometry_readings import state

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "sample"


def bulk(offset: float, imdl: float, imdr: float, flag: str = " ") -> LogEntry:
    reply = (f"cang:0.00000,cdis:0.00000,gvr:0.20000,tilt_angle_from_home:0.08727,"
             f"imdl:{imdl:.5f},imdr:{imdr:.5f},cvg:0.00000,mode:128,")  # fmt: skip
    return LogEntry(offset, flag, "bulk_data", reply)


def test_a_session_without_a_reading_is_read_as_totals_with_the_thesis_s_wheel_base():
    start = SessionStart.from_meta({"start": {"x": 1.0, "imdl": 2.0, "imdr": 2.0}})
    assert (start.odometers, start.wheel_base) == ("totals", 0.499)
    odometry = starting_odometry(start)
    assert odometry.reading is Reading.TOTALS and odometry.wheel_base == 0.499


def test_the_committed_sample_still_plays_to_where_it_drove():
    start = SessionStart.from_meta(read_meta(SAMPLE))
    assert start.odometers == "totals"
    _, log = open_log(SAMPLE)
    poses = list(replay_poses(log, start))
    assert len(poses) > 10
    assert poses[-1].x > 0.1 and all(math.isfinite(p.heading) for p in poses)


@pytest.mark.parametrize("meta", [
    {"odometers": "sideways"},
    {"odometers": 3},
    {"wheel_base": 0.0},
    {"wheel_base": 50},
    {"wheel_base": True},
])  # fmt: skip
def test_a_reading_meta_json_cannot_mean_is_not_used(meta):
    assert SessionStart.from_meta({"start": {"x": 1.0, **meta}}) == SessionStart()


def test_where_the_odometry_stands_is_recorded_with_its_reading_and_played_from_there():
    odometry = Odometry(Pose(1.0, 2.0, 0.5), wheel_base=0.467, reading="encoders")
    odometry.update(state(10.0, enc=(100, 200)))
    start = session_start(odometry, origin=10.5)
    assert (start.odometers, start.wheel_base, start.enc0, start.enc1) == ("encoders", 0.467,
                                                                           100, 200)  # fmt: skip
    assert start.offset == pytest.approx(-0.5)
    # Through meta.json's dictionary and back.
    again = SessionStart.from_meta({"start": {k: v for k, v in start.__dict__.items()
                                              if v is not None}})  # fmt: skip
    assert again == start
    played = starting_odometry(again)
    assert played.reading is Reading.ENCODERS and played.wheel_base == 0.467
    assert played.reference is not None and played.reference.enc0 == 100
    assert played.pose == Pose(1.0, 2.0, 0.5)


def test_increments_play_back_with_every_read_of_bulk_data_typed_ones_too():
    entries = [bulk(0.0, 0.0, 0.0)]
    for tick in range(1, 21):
        entries.append(bulk(tick * 0.05, 0.02, 0.02))
        if tick % 4 == 0:  # a typed `get bulk_data` reset the increments too
            entries.append(bulk(tick * 0.05 + 0.01, 0.002, 0.002, flag="G"))
    start = SessionStart(odometers="increments")
    poses = list(replay_poses(LogRead(entries, []), start))
    assert poses[-1].x == pytest.approx(20 * 0.02 + 5 * 0.002)
    # The playback shows the same.
    clock = VirtualClock()
    replayer = Replayer(Playback("increments", LogRead(entries, []), clock.now(), start=start))
    clock.advance(2.0)
    replayer.advance(clock.now(), lambda exchange: None)
    assert replayer.pose.x == pytest.approx(poses[-1].x)


def test_encoders_play_back_from_the_counts_read_after_each_poll():
    entries = []
    for tick in range(21):
        at = tick * 0.05
        entries.append(bulk(at, 0.0, 0.0))
        count = (65_400 + 40 * tick) % 65_536  # across the wrap
        entries.append(LogEntry(at + 0.002, " ", "enc0", str(count)))
        entries.append(LogEntry(at + 0.004, " ", "enc1", str(count)))
    start = SessionStart(odometers="encoders")
    poses = list(replay_poses(LogRead(entries, []), start))
    assert poses[-1].x == pytest.approx(800 / COUNTS_PER_METRE)
    clock = VirtualClock()
    replayer = Replayer(Playback("encoders", LogRead(entries, []), clock.now(), start=start))
    clock.advance(2.0)
    replayer.advance(clock.now(), lambda exchange: None)
    assert replayer.pose.x == pytest.approx(poses[-1].x)
    replayer.seek(clock.now(), 0.5)
    assert 0 < replayer.pose.x < poses[-1].x


@pytest.mark.parametrize(("firmware", "odometers"), [
    ("later", "auto"),
    ("giraff-x", "encoders"),
    ("thesis", "auto"),
])  # fmt: skip
def test_a_session_recorded_on_each_board_replays_to_the_live_pose(tmp_path, firmware, odometers):
    console = Console(firmware, odometers=odometers)
    console.run(TICK)
    console.hold(Intent.FORWARD, 1.0)  # recording starts mid-session
    recorder = SessionRecorder(tmp_path, RecordingSetup(port="sim"), console.clock.now)

    def begin() -> None:
        recorder.begin(session_start(console.loop.odometry, recorder.started_at))
        console.loop.subscribe(ExchangeTap(recorder.exchange))

    console.loop.between_ticks(begin)
    for tick in range(40):
        if tick % 10 == 5:  # typed while driving: resets a later board's increments
            console.loop.submit(lambda link: link.bulk())
        console.loop.press(Intent.FORWARD_LEFT)
        console.loop.tick()
        console.clock.advance(TICK)
    console.hold(Intent.FORWARD, 1.0)
    recorder.close()
    deadline = time.monotonic() + 5
    while "start" not in read_meta(recorder.path):
        assert time.monotonic() < deadline, "meta.json never got its start"
        time.sleep(0.01)
    start = SessionStart.from_meta(read_meta(recorder.path))
    assert start.odometers == console.loop.odometry.reading.value
    _, log = open_log(recorder.path)
    last = list(replay_poses(log, start))[-1]
    live = console.loop.odometry.pose
    # The log keeps five decimals of each reading (the original's format, B.2).
    assert (last.x, last.y, last.heading) == pytest.approx((live.x, live.y, live.heading),
                                                           abs=1e-4)  # fmt: skip
    assert console.error()[0] <= 0.01
