"""Legs across a room: measured by the numpy search, driven by D* Lite, the same way."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from giraff_console.planning.floorplan import Door, FloorPlan, Room
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.legs import GridLegs, polyline_length


def open_plan() -> tuple[FloorPlan, OccupancyGrid]:
    """A 10 m x 6 m room of 0.1 m cells with a wall across most of it, no outlines."""
    cells = np.full((60, 100), FREE, dtype=np.uint8)
    cells[[0, -1], :] = OCCUPIED
    cells[:, [0, -1]] = OCCUPIED
    cells[0:45, 50:53] = OCCUPIED
    rooms = {
        "west": Room("west", "", (2.0, 3.0), None, None),
        "east": Room("east", "", (8.0, 3.0), None, None),
        "far": Room("far", "", (9.5, 5.0), None, None),
    }
    doors = [
        Door("gap", ("west", "east"), (5.1, 0.7), 0.9, True),
        Door("far-door", ("east", "far"), (9.0, 4.5), 0.9, True),
    ]
    return FloorPlan("open", rooms, doors, None, None, Path("open.yaml")), OccupancyGrid(cells, 0.1)


@pytest.fixture
def legs() -> GridLegs:
    plan, grid = open_plan()
    return GridLegs(plan, grid.inflated(0.2))


def test_a_clear_straight_line_is_the_way(legs):
    assert legs.path((1.0, 3.0), (4.0, 2.0), "west") == [(1.0, 3.0), (4.0, 2.0)]


def test_the_way_round_a_wall_is_the_driven_legs_first_plan(legs):
    a, b = (2.0, 3.0), (8.0, 3.0)
    assert not legs.clear(a, b)
    measured = legs.path(a, b, "west")
    driven = legs.points(legs.leg(a, b, "west"))
    assert measured == driven
    assert measured is not None and len(measured) > 2
    assert all(legs.clear(p, q) for p, q in pairwise(measured))
    assert polyline_length(measured) > 6.0


def test_the_driven_leg_replans_round_what_is_sensed(legs):
    a, b = (2.0, 3.0), (8.0, 3.0)
    leg = legs.leg(a, b, "west")
    before = leg.cells()
    assert before is not None
    changes = legs.block([legs.grid.centre_of(*before[len(before) // 2])], 0.25)
    leg.update(changes)
    after = leg.cells()
    assert after is not None and after != before
    assert not any(legs.blocked[cell] for cell in after)


def test_a_room_without_an_outline_plans_every_leg_in_one_window(legs):
    # The box round the room's point and doors: what one leg finds through a door, the
    # leg going straight on finds too.
    window = legs.window((2.0, 3.0), (5.1, 0.7), "west")
    assert legs.window((5.1, 0.7), (2.0, 3.0), "west") == window
    assert legs.window((2.5, 2.5), (2.0, 3.0), "west") == window
    top, left, bottom, right = window
    for x, y in [(2.0, 3.0), (5.1, 0.7)]:
        row, col = legs.grid.cell_of(x, y)
        assert top <= row < bottom and left <= col < right


def test_a_straight_line_does_not_slip_between_two_cells_that_touch_at_a_corner():
    # The review's case: a line from corner to corner through the pinch of two blocked
    # cells that share only a corner: the searches do not cut corners, and neither may
    # the line that stands in for one.
    plan, _ = open_plan()
    cells = np.full((4, 4), FREE, dtype=np.uint8)
    cells[1, 2] = cells[2, 1] = OCCUPIED
    legs = GridLegs(plan, OccupancyGrid(cells, 0.1))
    assert not legs.clear((0.05, 0.35), (0.35, 0.05))
    assert legs.clear((0.05, 0.05), (0.05, 0.35))


def test_a_contact_seen_through_by_the_range_finder_leaves_nothing_of_its_disc(legs):
    # A contact is blocked with a wider disc than a range finder's hit; the beams that
    # later cross its cell free all of that disc, not only a hit's worth of it.
    before = legs.blocked.copy()
    legs.block([(3.0, 3.0)], 0.3 + 0.2)
    assert (legs.blocked & ~before).sum() > 0
    legs.see_through((1.0, 3.0), [(5.0, 3.0)], [False], 0.3)
    assert not legs.sensed
    assert (legs.blocked == before).all()


def test_forgetting_what_was_sensed_leaves_the_plans_own_cells(legs):
    before = legs.blocked.copy()
    legs.block([(3.0, 3.0), (7.0, 2.0)], 0.3)
    assert legs.forget_sensed()
    assert (legs.blocked == before).all() and not legs.sensed
    assert not legs.forget_sensed()  # nothing left to forget
