"""Speed profiles: jerk-limited, within the wheel, turn and doorway caps, at rest at both ends."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from giraff_console.motion.path import Drive, Rotation, Segment, gear_of
from giraff_console.motion.speed_profile import (
    MotionLimits,
    Profile,
    SlowZone,
    drive_profile,
    rotation_profile,
)
from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.robot.odometry import Pose

LIMITS = MotionLimits()
TICK = 0.001  # seconds between samples


def drive_of(*pieces: tuple[float, float, float]) -> Drive:
    """A drive from (length, k0, k1) pieces, each starting where the last one ended."""
    segments, pose = [], Pose()
    for length, k0, k1 in pieces:
        segment = Segment(pose, length, k0, k1)
        segments.append(segment)
        pose = segment.end
    return Drive(tuple(segments))


def straight(length: float) -> Drive:
    return drive_of((length, 0.0, 0.0))


def samples(profile: Profile) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s, v and a every millisecond, and at the very end."""
    # Python floats: at() is called every tick with them, and numpy scalars are slower.
    times = [*np.arange(0.0, profile.duration, TICK).tolist(), profile.duration]
    s, v, a = np.array([profile.at(t) for t in times]).T
    return s, v, a


def assert_drivable(profile: Profile, limits: MotionLimits) -> tuple[np.ndarray, np.ndarray]:
    """What every profile promises: under the cap, within a_max and j_max, never backing
    up, and at rest at its length when it ends. Returns the sampled s and v."""
    s, v, a = samples(profile)
    caps = np.array([profile.speed_cap_at(x) for x in s.tolist()])
    assert np.all(v <= caps + 1e-6)
    assert np.all(v >= -1e-9)
    assert np.all(np.abs(a) <= limits.a_max + 1e-9)
    # The last step is shorter than a tick, so it is left out of the jerk estimate.
    assert np.all(np.abs(np.diff(a[:-1])) / TICK <= limits.j_max + 1e-6)
    assert np.all(np.diff(s) >= 0.0)
    assert profile.at(profile.duration) == pytest.approx((profile.length, 0.0, 0.0), abs=1e-9)
    assert profile.at(profile.duration + 5.0) == profile.at(profile.duration)
    assert profile.at(-1.0) == (0.0, 0.0, 0.0)
    return s, v


def curvature_along(drive: Drive, s: np.ndarray) -> np.ndarray:
    """The path's curvature at each s, from the segments' own k0 and k1."""
    lengths = np.array([segment.length for segment in drive.segments])
    starts = np.concatenate(([0.0], np.cumsum(lengths)[:-1]))
    i = np.clip(np.searchsorted(starts, s) - 1, 0, len(lengths) - 1)
    k0 = np.array([segment.k0 for segment in drive.segments])[i]
    k1 = np.array([segment.k1 for segment in drive.segments])[i]
    return k0 + (k1 - k0) * np.clip((s - starts[i]) / lengths[i], 0.0, 1.0)


def assert_within_turn_limits(
    drive: Drive, s: np.ndarray, v: np.ndarray, limits: MotionLimits
) -> None:
    """The physical limits, from the path itself rather than from the profile's own caps:
    no wheel faster than v_max (A.2.3), no more sideways acceleration than allowed."""
    k = np.abs(curvature_along(drive, s))
    assert np.all(v * (1.0 + np.abs(gear_of(k))) <= limits.v_max + 1e-6)
    assert np.all(v * v * k <= limits.lateral_accel + 1e-6)


def rest_to_rest_time(length: float, limits: MotionLimits) -> float:
    """The S-curve time of a straight move long enough to cruise at v_max: jerk up, hold
    a_max (if v_max is high enough to need it), jerk down; cruise; the mirror to rest."""
    v, a, j = limits.v_max, limits.a_max, limits.j_max
    if v <= a * a / j:
        jerk_time, hold_time = math.sqrt(v / j), 0.0  # the acceleration peaks below a_max
    else:
        jerk_time, hold_time = a / j, v / a - a / j
    ramp_time = 2.0 * jerk_time + hold_time
    ramp_length = v * ramp_time / 2.0
    assert 2.0 * ramp_length < length, "too short to cruise"
    return 2.0 * ramp_time + (length - 2.0 * ramp_length) / v


@pytest.mark.parametrize("limits", [LIMITS, MotionLimits(j_max=0.5)], ids=["a_max", "jerk_only"])
def test_a_long_straight_cruises_at_v_max_in_the_s_curve_time(limits):
    profile = drive_profile(straight(10.0), limits)
    _, v = assert_drivable(profile, limits)
    assert v.max() == pytest.approx(limits.v_max, abs=1e-9)
    assert profile.duration == pytest.approx(rest_to_rest_time(10.0, limits), abs=1e-6)


def test_the_s_curve_time_of_a_ten_metre_straight_is_26_3_seconds():
    # 1.3 s to reach 0.4 m/s over 0.26 m, 23.7 s cruising, 1.3 s to stop.
    assert drive_profile(straight(10.0), LIMITS).duration == pytest.approx(26.3, abs=1e-6)


def test_a_short_straight_never_reaches_v_max_and_ends_at_rest_at_its_length():
    profile = drive_profile(straight(0.3), LIMITS)
    _, v = assert_drivable(profile, LIMITS)
    assert v.max() < LIMITS.v_max - 0.05
    assert profile.length == 0.3


def test_a_very_short_drive_still_ends_at_rest_at_its_length():
    profile = drive_profile(straight(1e-6), LIMITS)
    assert 0.0 < profile.duration < 0.1
    assert profile.at(profile.duration) == pytest.approx((1e-6, 0.0, 0.0), abs=1e-12)


def test_an_empty_drive_and_a_zero_rotation_take_no_time():
    for profile in (
        drive_profile(Drive(()), LIMITS),
        rotation_profile(Rotation(Pose(), 0.0), LIMITS),
    ):
        assert (profile.duration, profile.length) == (0.0, 0.0)
        assert profile.at(1.0) == (0.0, 0.0, 0.0)
        assert profile.time_at(1.0) == 0.0


def test_a_tight_turn_is_driven_at_the_wheel_cap():
    # Clothoid to k = 2 (vg = 0.499), 2 rad of arc, clothoid back, between straights.
    drive = drive_of((2.0, 0, 0), (0.8, 0, 2.0), (1.0, 2.0, 2.0), (0.8, 2.0, 0), (2.0, 0, 0))
    profile = drive_profile(drive, LIMITS)
    wheel_cap = LIMITS.v_max / (1.0 + 2.0 * TURN_RADIUS_M)
    assert wheel_cap < math.sqrt(LIMITS.lateral_accel / 2.0)  # the wheels are what binds
    s, v = assert_drivable(profile, LIMITS)
    turn = (s >= 2.0) & (s <= 4.6)
    assert v[turn].max() == pytest.approx(wheel_cap, abs=1e-6)
    assert v.max() == pytest.approx(LIMITS.v_max, abs=1e-9)  # and full speed outside it
    assert profile.speed_cap_at(3.0) == pytest.approx(wheel_cap)
    assert_within_turn_limits(drive, s, v, LIMITS)


def test_a_gentle_fast_turn_is_held_by_the_lateral_acceleration():
    limits = MotionLimits(lateral_accel=0.05)
    drive = drive_of((2.0, 0, 0), (3.0, 1.0, 1.0), (2.0, 0, 0))
    profile = drive_profile(drive, limits)
    lateral_cap = math.sqrt(0.05 / 1.0)
    assert profile.speed_cap_at(3.5) == pytest.approx(lateral_cap)
    s, v = assert_drivable(profile, limits)
    assert v[(s >= 2.0) & (s <= 5.0)].max() == pytest.approx(lateral_cap, abs=1e-6)
    assert_within_turn_limits(drive, s, v, limits)


def test_a_doorway_caps_the_speed_inside_it_and_only_there():
    door = SlowZone(4.0, 6.0, LIMITS.door_speed)
    profile = drive_profile(straight(10.0), LIMITS, [door])
    s, v = assert_drivable(profile, LIMITS)
    inside = (s >= door.start) & (s <= door.end)
    assert v[inside].max() == pytest.approx(door.speed, abs=1e-9)
    assert v[s < door.start].max() == pytest.approx(LIMITS.v_max, abs=1e-9)
    assert v[s > door.end].max() == pytest.approx(LIMITS.v_max, abs=1e-9)
    assert (profile.speed_cap_at(5.0), profile.speed_cap_at(2.0)) == (door.speed, LIMITS.v_max)


def test_a_hair_between_a_doorway_and_a_curve_joins_the_curve():
    # Not a piece of its own: ruckig would take 1e-12 m as already driven and jump it. The
    # straight hair gets the curve's cap, which is lower than its own.
    drive = drive_of((2.0, 0, 0), (2.0, 0.5, 0.5))
    profile = drive_profile(drive, LIMITS, [SlowZone(1.0, 2.0 - 1e-12, 0.2)])
    arc_cap = LIMITS.v_max / (1.0 + 0.5 * TURN_RADIUS_M)
    assert profile.speed_cap_at(2.0 - 1e-13) == pytest.approx(arc_cap)
    assert profile.speed_cap_at(3.0) == pytest.approx(arc_cap)
    assert profile.speed_cap_at(1.5) == 0.2
    s, v = assert_drivable(profile, LIMITS)
    assert_within_turn_limits(drive, s, v, LIMITS)


def test_a_doorway_starting_a_hair_after_the_start_does_not_make_the_robot_jump():
    profile = drive_profile(straight(2.0), LIMITS, [SlowZone(1e-30, 1.0, 0.25)])
    assert profile.at(0.0) == (0.0, 0.0, 0.0)
    assert profile.speed_cap_at(0.0) == 0.25
    assert_drivable(profile, LIMITS)


def test_a_quarter_turn_on_the_spot_ends_at_its_wheel_distance_within_rotation_speed():
    limits = MotionLimits(rotation_speed=0.15)
    profile = rotation_profile(Rotation(Pose(), math.pi / 2), limits)
    assert profile.length == pytest.approx(math.pi / 2 * TURN_RADIUS_M)
    _, v = assert_drivable(profile, limits)
    assert v.max() == pytest.approx(0.15, abs=1e-9)
    assert profile.speed_cap_at(0.2) == 0.15


def test_a_turn_to_the_right_has_the_same_profile_as_one_to_the_left():
    left = rotation_profile(Rotation(Pose(), math.pi / 2), LIMITS)
    right = rotation_profile(Rotation(Pose(), -math.pi / 2), LIMITS)
    assert (right.duration, right.length) == (left.duration, left.length)


def test_time_at_is_the_inverse_of_at():
    profile = drive_profile(straight(10.0), LIMITS, [SlowZone(4.0, 6.0, 0.25)])
    for t in np.linspace(0.2, profile.duration - 0.2, 40):
        assert profile.time_at(profile.at(t)[0]) == pytest.approx(t, abs=1e-6)
    for s in np.linspace(0.0, 10.0, 41):
        assert profile.at(profile.time_at(s))[0] == pytest.approx(s, abs=1e-9)
    assert (profile.time_at(-1.0), profile.time_at(11.0)) == (0.0, profile.duration)


def test_the_same_drive_gets_the_same_profile():
    drive = drive_of((1.0, 0, 1.5), (2.0, 1.5, -1.0), (0.5, -1.0, -1.0))
    first, second = drive_profile(drive, LIMITS), drive_profile(drive, LIMITS)
    assert first.duration == second.duration
    assert [first.at(t) for t in (0.5, 2.0, 4.0)] == [second.at(t) for t in (0.5, 2.0, 4.0)]


def test_a_forty_metre_drive_of_thirty_segments_is_profiled_well_within_50_ms():
    # Arcs and clothoids of |k| up to 1.5, turning left and right in turn.
    pieces = [(40.0 / 30, (-1) ** i * 1.5, (-1) ** i * 1.5 * (i % 3 == 0)) for i in range(30)]
    drive = drive_of(*pieces)
    doors = [SlowZone(5.0, 6.0, 0.25), SlowZone(18.0, 19.0, 0.25), SlowZone(33.0, 34.0, 0.25)]
    best = math.inf
    for _ in range(3):
        started = time.perf_counter()
        profile = drive_profile(drive, LIMITS, doors)
        best = min(best, time.perf_counter() - started)
    assert profile.length == pytest.approx(40.0)
    assert best < 0.050


@pytest.mark.parametrize(
    "wrong",
    [
        {"v_max": 0.0},
        {"a_max": -0.5},
        {"j_max": 0.0},
        {"j_max": math.inf},
        {"lateral_accel": math.nan},
        {"rotation_speed": 0.5},
        {"door_speed": 0.5},
    ],
)
def test_invalid_limits_are_refused(wrong):
    with pytest.raises(ValueError):
        MotionLimits(**wrong)


@pytest.mark.parametrize("start, end, speed", [(2.0, 2.0, 0.25), (3.0, 2.0, 0.25), (1, 2, 0)])
def test_invalid_slow_zones_are_refused(start, end, speed):
    with pytest.raises(ValueError):
        SlowZone(start, end, speed)


def test_a_drive_ruckig_cannot_plan_raises_a_value_error_that_says_where():
    limits = MotionLimits(v_max=1e-12, door_speed=1e-12, rotation_speed=1e-12)
    with pytest.raises(ValueError, match=r"ruckig could not plan 0\.\.10 m"):
        drive_profile(straight(10.0), limits)


segments = st.tuples(
    st.floats(0.01, 5.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0), st.booleans()
).map(lambda p: (p[0], p[1], p[1] if p[3] else p[2]))  # arcs as often as clothoids


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pieces=st.lists(segments, min_size=1, max_size=4), data=st.data())
def test_any_drive_keeps_every_limit(pieces, data):
    drive = drive_of(*pieces)
    zones = data.draw(
        st.lists(
            st.tuples(
                st.floats(-1.0, drive.length + 1.0), st.floats(0.01, 2.0), st.floats(0.1, 0.4)
            ),
            max_size=2,
        ).map(lambda zs: [SlowZone(start, start + width, speed) for start, width, speed in zs])
    )
    profile = drive_profile(drive, LIMITS, zones)
    assert profile.length == pytest.approx(drive.length)
    s, v = assert_drivable(profile, LIMITS)
    assert_within_turn_limits(drive, s, v, LIMITS)
