"""Which markers the camera could read from a point (planning/marker_sight.py), and how
far off it reads them (camera/marker_reach.py)."""

from __future__ import annotations

import math

import pytest

from giraff_console.camera.marker_reach import (
    FACING_PX,
    READ_PX,
    STANDARD_SIZE_M,
    facing_reach,
    least_size,
    read_reach,
)
from giraff_console.planning.landmarks import marker_poses
from giraff_console.planning.marker_sight import visible_markers
from giraff_console.planning.walls import WallSegment, wall_segments
from giraff_console.robot.odometry import Pose
from tests.missions.site import PLAN

MARKERS = marker_poses(PLAN)
DOCK = (2.0, 7.0)


def test_markers_behind_walls_facing_away_or_out_of_reach_are_not_seen():
    reach = read_reach(STANDARD_SIZE_M)
    seen = dict(visible_markers(MARKERS, wall_segments(PLAN), DOCK, STANDARD_SIZE_M))
    # The dock's own markers, and the corridor's beside its door is behind the wall.
    assert {16, 105, 106, 107} <= set(seen)
    assert 17 not in seen  # in the corridor, facing away and behind the wall
    assert all(math.dist(DOCK, (MARKERS[i].x, MARKERS[i].y)) <= reach for i in seen)
    # Marker 16 hangs north of the dock's point, a little to the east.
    assert seen[16] == pytest.approx(math.atan2(3.0, 0.95))


def test_larger_markers_are_seen_from_further_off():
    walls = wall_segments(PLAN)
    near = visible_markers(MARKERS, walls, DOCK, STANDARD_SIZE_M)
    far = visible_markers(MARKERS, walls, DOCK, 2 * STANDARD_SIZE_M)
    assert set(near) < set(far)
    assert [marker_id for marker_id, _ in far][: len(near)] == [m for m, _ in near]


def test_reaches_are_pixels_on_the_camera_turned_into_metres():
    # A 16 cm marker is read at 4 m and gives its facing to 3 m (the thesis's camera,
    # 800 pixels over 90 degrees); twice the size, twice as far.
    assert read_reach(0.16) == pytest.approx(4.0)
    assert facing_reach(0.16) == pytest.approx(3.05, abs=0.01)
    assert read_reach(0.32) == pytest.approx(2 * read_reach(0.16))
    assert facing_reach(0.16) < read_reach(0.16)
    assert least_size(read_reach(0.21), READ_PX) == pytest.approx(0.21)
    assert least_size(facing_reach(0.21), FACING_PX) == pytest.approx(0.21)


def test_a_marker_cut_by_a_corner_is_not_seen():
    marker = {7: Pose(0.0, 0.0, math.pi / 2)}  # on a wall along y = 0, facing +y
    here = (0.0, 2.0)
    # A wall's end 2 cm short of the line to the marker's centre: it hides the left edge
    # of the 16 cm square, though the centre is in sight.
    corner = [WallSegment((-0.5, 1.0), (-0.02, 1.0))]
    assert visible_markers(marker, [], here, STANDARD_SIZE_M) == [(7, -math.pi / 2)]
    assert visible_markers(marker, corner, here, STANDARD_SIZE_M) == []
    clear = [WallSegment((-0.5, 1.0), (-0.1, 1.0))]
    assert visible_markers(marker, clear, here, STANDARD_SIZE_M) == [(7, -math.pi / 2)]
