"""Playback hands out the pose filter's recorded estimate at the playback position, carried
along between recorded estimates by the odometry it integrates again (issue 14)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import LogEntry, LogRead, read_log
from giraff_console.recording.estimates import RecordedEstimate
from giraff_console.recording.playback import Playback, open_estimates
from giraff_console.robot.odometry import Pose
from giraff_console.robot.replay import CHECKPOINT_ENTRIES, Replayer, carried

SAMPLE = Path(__file__).resolve().parents[2] / "recordings" / "sample"
POLL = 0.05
STEP = 0.01  # metres each wheel turns per poll: straight along the odometry's +x


def poll(i: int) -> LogEntry:
    wheels = i * STEP
    reply = (f"cang:0.00000,cdis:0.00000,gvr:0.20000,tilt_angle_from_home:0.08727,"
             f"imdl:{wheels:.5f},imdr:{wheels:.5f},cvg:0.00000,mode:128,")  # fmt: skip
    return LogEntry(round(i * POLL, 3), " ", "bulk_data", reply)


def recorded(offset: float, pose: tuple[float, float, float], odometry_x: float,
             scale: float, corrected_at: float | None = None) -> RecordedEstimate:  # fmt: skip
    covariance = ((0.0025 * scale, 1e-4, 0.0), (1e-4, 0.0036 * scale, 0.0), (0.0, 0.0, 0.001))
    return RecordedEstimate(offset, pose, (odometry_x, 0.0, 0.0), covariance,  # type: ignore[arg-type]
                            sigma_m=0.06 * scale, sigma_heading=0.03, ellipse=(0.06, 0.05, 0.0),
                            landmarks=True, found=corrected_at is not None,
                            seen=(7,) if corrected_at is not None else (),
                            corrected_at=corrected_at)  # fmt: skip


# The first poll is the odometry's reference: poll i has it at i * STEP along +x.
LOG = LogRead([poll(i) for i in range(61)], [])
# Recorded facing +y, a metre from the odometry's pose, before any marker; then corrected.
ESTIMATES = [
    recorded(0.10, (1.0, 2.0, math.pi / 2), odometry_x=0.02, scale=1.0),
    recorded(1.00, (1.3, 2.25, math.pi / 2 + 0.1), odometry_x=0.20, scale=0.5, corrected_at=0.95),
    recorded(2.00, (1.4, 3.3, math.pi / 2 + 0.1), odometry_x=0.40, scale=0.6, corrected_at=0.95),
]


def replayer(log: LogRead = LOG, estimates=ESTIMATES) -> tuple[Replayer, VirtualClock]:
    clock = VirtualClock()
    return Replayer(Playback("estimates", log, clock.now(), estimates=estimates)), clock


def test_a_seek_onto_a_recorded_estimate_gives_it_exactly():
    replay, clock = replayer()
    for index in (1, 0, 2, 1):
        replay.seek(clock.now(), ESTIMATES[index].offset)
        estimate, expected = replay.estimate, ESTIMATES[index]
        assert estimate is not None
        assert (estimate.pose.x, estimate.pose.y, estimate.pose.heading) == expected.pose
        assert estimate.odometry == Pose(*expected.odometry)
        # The odometry integrated again stands where the recorded one did.
        assert replay.odometry.pose.x == pytest.approx(expected.odometry[0], abs=1e-9)
        assert estimate.covariance == expected.covariance
        assert (estimate.sigma_m, estimate.found, estimate.seen) == (
            expected.sigma_m, expected.found, expected.seen)  # fmt: skip
        # The pose the console shows during the playback is the estimate's, as live.
        assert replay.pose == estimate.pose


def test_between_two_estimates_the_last_is_carried_along_by_the_odometry():
    replay, clock = replayer()
    replay.seek(clock.now(), 0.6)  # ten polls after the first estimate: 0.1 m on
    estimate = replay.estimate
    assert estimate is not None
    # Forward for the robot, which the estimate has facing +y: up the map.
    assert estimate.pose.x == pytest.approx(1.0, abs=1e-9)
    assert estimate.pose.y == pytest.approx(2.1, abs=1e-9)
    assert estimate.pose.heading == pytest.approx(math.pi / 2)
    assert estimate.odometry.x == pytest.approx(0.12, abs=1e-9)
    assert estimate.covariance == ESTIMATES[0].covariance  # the last recorded


def test_before_the_first_estimate_there_is_none_and_the_pose_is_the_odometrys():
    replay, clock = replayer()
    replay.seek(clock.now(), 0.05)
    assert replay.estimate is None
    assert replay.pose == replay.odometry.pose


def test_playing_through_gives_what_seeking_gives():
    replay, clock = replayer()
    seen = []
    while not replay.playback.finished(clock.now()):
        replay.advance(clock.now(), lambda exchange: None)
        seen.append((replay.playback.position(clock.now()), replay.estimate))
        clock.advance(0.0173)
    sought, _ = replayer()
    for position, estimate in seen[::7]:
        sought.seek(clock.now(), position)
        if estimate is None:
            assert sought.estimate is None
            continue
        assert sought.estimate is not None
        assert sought.estimate.pose.x == pytest.approx(estimate.pose.x, abs=1e-9)
        assert sought.estimate.pose.y == pytest.approx(estimate.pose.y, abs=1e-9)
        assert sought.estimate.covariance == estimate.covariance
    assert sum(estimate is not None for _, estimate in seen) > 50


def test_a_seek_across_checkpoints_carries_the_estimate_as_playing_did():
    entries = [poll(i) for i in range(3 * CHECKPOINT_ENTRIES)]
    last = entries[-1].offset
    estimates = [recorded(0.5, (5.0, 5.0, math.pi), odometry_x=0.10, scale=1.0)]
    replay, clock = replayer(LogRead(entries, []), estimates)
    replay.playback.set_speed(clock.now(), 16.0)
    while not replay.playback.finished(clock.now()):
        replay.advance(clock.now(), lambda exchange: None)
        clock.advance(0.05)
    replay.seek(clock.now(), last)
    estimate = replay.estimate
    assert estimate is not None
    # Facing -x, the estimate goes the other way from the odometry's +x.
    travelled = replay.odometry.pose.x - 0.10
    assert travelled > 30
    assert estimate.pose.x == pytest.approx(5.0 - travelled, abs=1e-6)
    replay.seek(clock.now(), 0.2)
    assert replay.estimate is None


def test_a_recorded_correction_time_is_put_on_the_consoles_clock():
    replay, clock = replayer()
    clock.advance(100.0)
    replay.seek(clock.now(), 1.5)
    estimate = replay.estimate
    assert estimate is not None and estimate.corrected_at is not None
    # Corrected 0.55 s of the recording before the position shown now.
    assert clock.now() - estimate.corrected_at == pytest.approx(1.5 - 0.95)


def test_a_session_recorded_before_the_filter_plays_without_an_estimate():
    log = read_log(SAMPLE / "control.log")
    estimates = open_estimates(SAMPLE)
    assert estimates.entries == [] and estimates.problems == []
    replay, clock = replayer(log, estimates.entries)
    for offset in (0.0, log.duration / 2, log.duration):
        replay.seek(clock.now(), offset)
        assert replay.estimate is None
        assert replay.pose == replay.odometry.pose
    assert replay.pose.x > 0.5  # the sample drives on: the odometry's pose is shown


def test_carrying_along_takes_the_step_in_the_estimates_own_frame():
    step = carried(Pose(1.0, 1.0, math.pi / 2), since=Pose(0.0, 0.0, 0.0),
                   now=Pose(0.1, 0.0, 0.2))  # fmt: skip
    assert (step.x, step.y) == pytest.approx((1.0, 1.1))
    assert step.heading == pytest.approx(math.pi / 2 + 0.2)
    unchanged = Pose(1.0, 2.0, 3.0)
    assert carried(unchanged, Pose(4.0, 5.0, 6.0), Pose(4.0, 5.0, 6.0)) == unchanged
