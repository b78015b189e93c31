"""The three wheel readings (totals, increments, encoders) and the heading from the wheels,
on hand-built motor states."""

from __future__ import annotations

import math

import pytest

from giraff_console.link import BoardFeatures, MotorState
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.wheel_odometers import (
    COUNTS_PER_METRE,
    Reading,
    choose_reading,
    counts_travel,
)

THESIS = BoardFeatures("1.1.112p-sim, 2013-06-01", False, False, False, False)
LATER = BoardFeatures("1.4.226-sim, 2015-09-14", True, True, True, False)
LATER_WITHOUT_ENCODERS = BoardFeatures(None, False, True, True, False)


def state(at: float, imdl: float | None = 0.0, imdr: float | None = 0.0,
          enc: tuple[int, int] | None = None) -> MotorState:  # fmt: skip
    enc0, enc1 = enc if enc is not None else (None, None)
    return MotorState(cang=0.0, cdis=0.0, gvr=0.0, speed=0.0, cvg=0.0, tilt=None, imdl=imdl,
                      imdr=imdr, mode=0, received_at=at, enc0=enc0, enc1=enc1)  # fmt: skip


def test_totals_are_differenced():
    odometry = Odometry(reading="totals")
    odometry.update(state(0.0, 5.0, 5.0))  # the reference: nothing moved yet
    odometry.update(state(0.05, 5.02, 5.02))
    odometry.update(state(0.10, 5.04, 5.04))
    assert odometry.pose.x == pytest.approx(0.04)
    assert odometry.distance == pytest.approx(0.04)


def test_totals_that_restart_keep_the_pose_and_take_a_new_reference():
    odometry = Odometry(reading="totals")
    odometry.update(state(0.0, 5.0, 5.0))
    odometry.update(state(0.05, 5.02, 5.02))
    odometry.update(state(0.10, 0.0, 0.0))  # power-cycled: -5 m in 50 ms is no travel
    assert odometry.pose.x == pytest.approx(0.02)
    odometry.update(state(0.15, 0.01, 0.01))
    assert odometry.pose.x == pytest.approx(0.03)


def test_increments_are_taken_as_they_come():
    odometry = Odometry(reading="increments")
    odometry.update(state(0.0, 0.7, 0.7))  # since power-up, or the last read: unknown
    for tick in range(1, 11):
        odometry.update(state(tick * 0.05, 0.02, 0.02))
    assert odometry.pose.x == pytest.approx(0.2)
    assert odometry.pose.heading == 0.0


def test_an_increment_further_than_a_wheel_goes_is_not_believed():
    odometry = Odometry(reading="increments")
    odometry.update(state(0.0))
    odometry.update(state(0.05, 3.0, 3.0))
    assert odometry.pose == Pose()


def test_increments_count_every_read_and_totals_only_the_polls():
    typed = state(0.0)
    assert Odometry(reading="increments").wants(typed, automatic=False)
    assert not Odometry(reading="totals").wants(typed, automatic=False)
    assert Odometry(reading="totals").wants(typed, automatic=True)
    assert not Odometry(reading="encoders").wants(typed, automatic=True)  # no counts


def test_encoders_are_counts_per_metre():
    odometry = Odometry(reading="encoders")
    odometry.update(state(0.0, enc=(1000, 1000)))
    odometry.update(state(0.5, enc=(1000 + 200, 1000 + 200)))
    assert odometry.pose.x == pytest.approx(200 / COUNTS_PER_METRE)


@pytest.mark.parametrize(("last", "now", "counts"), [
    (65_500, 30, 66),  # forwards across the wrap
    (30, 65_500, -66),  # backwards across it
    (100, 300, 200),
    (300, 100, -200),
])  # fmt: skip
def test_encoders_take_the_shorter_way_round_the_wrap(last, now, counts):
    assert counts_travel(last, now) == pytest.approx(counts / COUNTS_PER_METRE)


def test_encoders_across_the_wrap_drive_on_smoothly():
    odometry = Odometry(reading="encoders")
    count = 65_000
    odometry.update(state(0.0, enc=(count, count)))
    for tick in range(1, 41):  # 40 ticks of 40 counts: over the wrap at 65,536
        count = (count + 40) % 65_536
        odometry.update(state(tick * 0.05, enc=(count, count)))
    assert odometry.pose.x == pytest.approx(1600 / COUNTS_PER_METRE)


def test_a_sample_without_what_the_reading_needs_is_refused():
    from giraff_console.protocol import ProtocolError

    with pytest.raises(ProtocolError, match="encoder counts"):
        Odometry(reading="encoders").update(state(0.0))


def test_the_heading_comes_from_the_wheels_and_the_wheel_base():
    # A quarter circle of radius 1 m to the left: the outer (right) wheel goes further.
    for base in (0.499, 0.467):
        odometry = Odometry(wheel_base=base, reading="increments")
        odometry.update(state(0.0))
        steps = 200
        arc = math.pi / 2 / steps  # radians a step
        for step in range(1, steps + 1):
            left, right = arc * (1 - base / 2), arc * (1 + base / 2)
            odometry.update(state(step * 0.05, left, right))
        pose = odometry.pose
        assert pose.heading == pytest.approx(math.pi / 2, abs=1e-12)
        assert (pose.x, pose.y) == pytest.approx((1.0, 1.0), abs=1e-5)


def test_rotating_on_the_spot_turns_without_moving():
    odometry = Odometry(reading="increments")
    odometry.update(state(0.0))
    quarter = math.pi / 2 * 0.499 / 2  # each wheel's metres for 90 degrees
    odometry.update(state(1.0, quarter, -quarter))  # left forward: clockwise
    assert odometry.pose.heading == pytest.approx(-math.pi / 2)
    assert (odometry.pose.x, odometry.pose.y) == (0.0, 0.0)


def test_another_reading_keeps_the_pose_and_counts_the_first_increments():
    odometry = Odometry(reading="totals")
    odometry.update(state(0.0, 2.0, 2.0))
    odometry.update(state(0.05, 2.02, 2.02))
    odometry.use("increments")
    # What the wheels did since the read at 0.05, which that read reset: real travel.
    odometry.update(state(0.10, 0.02, 0.02))
    odometry.update(state(0.15, 0.02, 0.02))
    assert odometry.reading is Reading.INCREMENTS
    assert odometry.pose.x == pytest.approx(0.06)


def test_after_a_change_to_totals_the_first_sample_is_only_a_reference():
    odometry = Odometry(reading="increments")
    odometry.update(state(0.0, 0.0, 0.0))
    odometry.update(state(0.05, 0.02, 0.02))
    odometry.use("totals")
    odometry.update(state(0.10, 3.0, 3.0))  # metres since power-up: no step on its own
    odometry.update(state(0.15, 3.02, 3.02))
    assert odometry.pose.x == pytest.approx(0.04)


def test_the_first_increments_after_a_reset_count_if_the_wheels_could_go_that_far():
    odometry = Odometry(reading="increments")
    odometry.update(state(0.0, 0.0, 0.0))
    odometry.reset(Pose(1.0, 0.0, 0.0))  # a board that restarted: the pose stays
    odometry.update(state(0.05, 0.02, 0.02))
    assert odometry.pose.x == pytest.approx(1.02)
    odometry.use("increments")
    odometry.update(state(0.10, 0.9, 0.9))  # 0.9 m in 50 ms: garbage, not travel
    assert odometry.pose.x == pytest.approx(1.02)
    odometry.update(state(0.15, 0.02, 0.02))  # but it is the reference
    assert odometry.pose.x == pytest.approx(1.04)


def test_the_very_first_increments_and_an_older_sample_are_only_a_reference():
    odometry = Odometry(reading="increments")
    odometry.update(state(5.0, 0.02, 0.02))  # since some read nobody knows the time of
    assert odometry.pose.x == 0.0
    odometry.update(state(5.05, 0.02, 0.02))
    odometry.reset(Pose())  # a playback seeking back to its start...
    odometry.update(state(1.0, 0.02, 0.02))  # ...without a reference there
    assert odometry.pose.x == 0.0


def test_a_wheel_base_that_is_not_positive_is_refused():
    with pytest.raises(ValueError):
        Odometry(wheel_base=0.0)


@pytest.mark.parametrize(("setting", "features", "reading", "said"), [
    ("auto", THESIS, Reading.TOTALS, False),
    ("auto", LATER, Reading.INCREMENTS, False),
    ("totals", LATER, Reading.TOTALS, False),
    ("increments", THESIS, Reading.INCREMENTS, False),
    ("encoders", LATER, Reading.ENCODERS, False),
    ("encoders", THESIS, Reading.TOTALS, True),
    ("encoders", LATER_WITHOUT_ENCODERS, Reading.INCREMENTS, True),
])  # fmt: skip
def test_the_reading_follows_the_setting_and_the_board(setting, features, reading, said):
    chosen, message = choose_reading(setting, features)
    assert chosen is reading
    assert (message is not None) == said
    if said:
        assert "has none" in message and f"as {reading} instead" in message
