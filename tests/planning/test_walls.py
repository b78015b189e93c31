"""Walls as segments: outlines with their doorways cut out, closed doors across them."""

from __future__ import annotations

from pathlib import Path

import pytest

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.walls import FRAME_M, wall_segments

TWO_ROOMS = """\
name: two rooms
rooms:
  west: {at: [1, 1], outline: [[0, 0], [2, 0], [2, 2], [0, 2]]}
  east: {at: [3, 1], outline: [[2, 0], [4, 0], [4, 2], [2, 2]]}
doors:
  - {between: [west, east], at: [2, 1], width: 0.8, id: middle}
"""


@pytest.fixture
def plan(tmp_path: Path):
    path = tmp_path / "two.yaml"
    path.write_text(TWO_ROOMS)
    return load_floorplan(path)


def total(segments, kind):
    return sum(segment.length for segment in segments if segment.kind == kind)


def test_an_open_doorway_is_a_gap_with_a_frame_on_each_side(plan):
    segments = wall_segments(plan)
    # Two 8 m perimeters; the shared wall is in both, cut by the doorway in both.
    assert total(segments, "wall") == pytest.approx(16 - 2 * (0.8 + 2 * FRAME_M))
    assert total(segments, "frame") == pytest.approx(2 * 2 * FRAME_M)
    assert total(segments, "door") == 0
    # Nothing lies across the gap: no segment covers the point x = 2, y = 1.
    for segment in segments:
        (ax, ay), (bx, by) = segment.a, segment.b
        assert not (ax == bx == 2 and min(ay, by) < 1 < max(ay, by))


def test_a_closed_door_spans_its_doorway(plan):
    segments = wall_segments(plan, closed=frozenset({"middle"}))
    assert total(segments, "door") == pytest.approx(2 * 0.8)
    assert total(segments, "wall") + total(segments, "frame") + total(
        segments, "door"
    ) == pytest.approx(16)
