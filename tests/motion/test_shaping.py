"""Path shaping: clothoid turns that fit their corners, turns on the spot where none does."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from giraff_console.motion.path import Drive, Rotation, Segment, wrap
from giraff_console.motion.shaping import TurnLimits, shape, turn_shape
from giraff_console.robot.odometry import Pose

LIMITS = TurnLimits()


def drives(sections):
    return [section for section in sections if isinstance(section, Drive)]


def assert_continuous(sections, start, end):
    """Every piece starts where the one before ended, heading and curvature included."""
    here = None
    for section in sections:
        pieces = section.segments if isinstance(section, Drive) else [section]
        for piece in pieces:
            begin = piece.start if isinstance(section, Drive) else piece.at
            if here is not None:
                assert math.dist((begin.x, begin.y), (here.x, here.y)) < 1e-6
                assert abs(wrap(begin.heading - here.heading)) < 1e-6
            here = piece.end
    for drive in drives(sections):
        assert drive.segments[0].k0 == 0 and drive.segments[-1].k1 == 0  # from rest, straight
        for a, b in pairwise(drive.segments):
            assert a.k1 == pytest.approx(b.k0, abs=1e-12)  # the gear ratio never jumps
    first = sections[0].at if isinstance(sections[0], Rotation) else sections[0].start
    assert (first.x, first.y) == pytest.approx(start)
    assert (here.x, here.y) == pytest.approx(end, abs=1e-6)


def test_a_straight_path_already_faced_is_one_line():
    sections = shape([(0, 0), (3, 0)], heading=0.0)
    assert len(sections) == 1 and len(sections[0].segments) == 1
    assert sections[0].length == pytest.approx(3)


def test_the_robot_turns_on_the_spot_to_face_the_first_leg_and_the_goal_heading():
    sections = shape([(0, 0), (0, 2)], heading=0.0, goal_heading=math.pi)
    assert isinstance(sections[0], Rotation) and sections[0].angle == pytest.approx(math.pi / 2)
    assert isinstance(sections[-1], Rotation) and sections[-1].angle == pytest.approx(math.pi / 2)
    assert_continuous(sections, (0, 0), (0, 2))


def test_a_corner_with_room_is_a_clothoid_turn_without_stopping():
    sections = shape([(0, 0), (5, 0), (5, 5)], heading=0.0)
    assert len(sections) == 1  # one drive: no stop
    kinds = [(round(s.k0, 3), round(s.k1, 3)) for s in sections[0].segments]
    assert kinds[0] == (0, 0) and kinds[-1] == (0, 0)
    peak = max(abs(s.k1) for s in sections[0].segments)
    assert 0 < peak <= LIMITS.max_curvature + 1e-9
    assert all(abs(s.sharpness) <= LIMITS.max_sharpness + 1e-9 for s in sections[0].segments)
    assert_continuous(sections, (0, 0), (5, 5))
    assert sections[0].end.heading == pytest.approx(math.pi / 2)


def test_the_smoothest_turn_that_fits_is_taken():
    roomy = shape([(0, 0), (20, 0), (20, 20)], heading=0.0)[0]
    cramped = shape([(0, 0), (1.5, 0), (1.5, 3)], heading=0.0)[0]
    sharpness = [max(abs(s.sharpness) for s in d.segments) for d in (roomy, cramped)]
    assert sharpness[0] == pytest.approx(LIMITS.min_sharpness)
    assert sharpness[1] > sharpness[0]


def test_a_corner_too_cramped_for_any_curve_is_turned_on_the_spot():
    sections = shape([(0, 0), (0.3, 0), (0.3, 0.3)], heading=0.0)
    assert [type(s) for s in sections] == [Drive, Rotation, Drive]
    assert sections[1].angle == pytest.approx(math.pi / 2)
    assert_continuous(sections, (0, 0), (0.3, 0.3))


def test_a_turn_whose_way_round_is_blocked_becomes_a_turn_on_the_spot():
    def only_the_polyline(a, b):
        return all(abs(p[1]) < 1e-9 or abs(p[0] - 5) < 1e-9 for p in (a, b))

    sections = shape([(0, 0), (5, 0), (5, 5)], heading=0.0, clear=only_the_polyline)
    assert [type(s) for s in sections] == [Drive, Rotation, Drive]


def test_a_turn_leaves_and_rejoins_the_lines_a_tangent_length_from_the_corner():
    for deflection in (0.3, -1.0, math.pi / 2, -2.5):
        tangent, pieces = turn_shape(deflection, 2.0, LIMITS.max_curvature)
        here = Pose()
        for length, k0, k1 in pieces:
            here = Segment(here, length, k0, k1).end
        corner = (tangent, 0.0)
        assert here.heading == pytest.approx(deflection)
        assert here.x == pytest.approx(corner[0] + tangent * math.cos(deflection))
        assert here.y == pytest.approx(corner[1] + tangent * math.sin(deflection))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=2, max_size=8),
       st.floats(-math.pi, math.pi))  # fmt: skip
def test_any_polyline_is_shaped_continuously_within_the_limits(points, heading):
    sections = shape(points, heading)
    if not sections:
        return
    assert_continuous(sections, points[0], points[-1])
    for drive in drives(sections):
        for segment in drive.segments:
            assert max(abs(segment.k0), abs(segment.k1)) <= LIMITS.max_curvature + 1e-9
            assert abs(segment.sharpness) <= LIMITS.max_sharpness + 1e-9
