"""Doorways crossed square on only where there is a wall to cross (issue 16): the
outline's wall, or on a plan without outlines the grid's occupied cells either side."""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

import pytest

from giraff_console.planning.floorplan import FloorPlan, load_floorplan
from giraff_console.planning.route_planner import PlannedPath, RoutePlanner, walls_of
from giraff_console.planning.walls import doorway, grid_jambs
from tests.planning.scanned_building import write_scanned_plan

# The scanned building with a door half-way along the corridor, in open floor, as an
# importer puts one on a lane. With `outline`, the corridor has the outline a user drew
# to get `go` to run; the door is not on it.
OPEN_FLOOR_DOOR = """\
name: Scanned home, a door in open floor
rooms:
  corridor: {{at: [3, 1]{outline}}}
  east-end: {{at: [11, 1]}}
  west-room: {{at: [2, 5]}}
doors:
  - {{between: [corridor, east-end], at: [7.5, 1]}}
  - {{between: [corridor, west-room], at: [2, 2.05], width: 1.0}}
grid:
  image: {image}
  resolution: {resolution}
  origin: [{origin_x}, {origin_y}, 0.0]
"""
CORRIDOR_OUTLINE = ", outline: [[0, 0], [12, 0], [12, 2], [0, 2]]"


def open_floor_plan(tmp_path: Path, outline: str = "") -> FloorPlan:
    return load_floorplan(write_scanned_plan(tmp_path, OPEN_FLOOR_DOOR, outline=outline))


def planner_for(plan: FloorPlan) -> RoutePlanner:
    return RoutePlanner(plan, walls_of(plan))


def through_the_doors(planned: PlannedPath) -> float:
    """The length of the straight lines from the start through each door's centre."""
    return sum(math.dist(a, b) for a, b in pairwise(planned.route.path))


@pytest.mark.parametrize("outline", [CORRIDOR_OUTLINE, ""], ids=["outlined", "no-outline"])
def test_a_door_in_open_floor_is_driven_straight_through(tmp_path, outline):
    # Before, the outline's nearest edge, a metre away, had the door crossed "square"
    # to the corridor: a hop to the side and back, 9.25 m where the way is 8.00 m.
    planned = planner_for(open_floor_plan(tmp_path, outline)).between_rooms("corridor", "east-end")
    assert planned.doorways == frozenset()
    assert through_the_doors(planned) == pytest.approx(8.0)
    assert planned.length_m == pytest.approx(8.0, abs=0.02)


def test_a_door_in_a_scanned_wall_is_crossed_square_on(tmp_path):
    planned = planner_for(open_floor_plan(tmp_path)).between_rooms("corridor", "west-room")
    assert planned.doorways == {(2.0, 2.05)}
    path = planned.path
    i = path.index((2.0, 2.05))
    # Straight through, square to the wall (along y), from the corridor into the room.
    before, after = path[i - 1], path[i + 1]
    assert before[0] == pytest.approx(2.0) and after[0] == pytest.approx(2.0)
    assert before[1] < 2.05 - 0.4 and after[1] > 2.05 + 0.4


def test_a_door_on_an_outline_is_crossed_square_on_as_before(tmp_path):
    planner = planner_for(open_floor_plan(tmp_path, CORRIDOR_OUTLINE))
    planned = planner.between_rooms("west-room", "corridor")
    assert (2.0, 2.05) in planned.doorways
    i = planned.path.index((2.0, 2.05))
    before, after = planned.path[i - 1], planned.path[i + 1]
    assert before[0] == after[0] == pytest.approx(2.0) and before[1] > after[1]


def test_the_jambs_of_a_scanned_doorway_are_the_walls_either_side(tmp_path):
    plan = load_floorplan(write_scanned_plan(tmp_path))
    grid = walls_of(plan)
    assert grid is not None
    doors = {door.id: door for door in plan.doors}
    # A 1.0 m gap, x 1.5 to 2.5, in the wall at y 2.0 to 2.1: the cells beside it.
    jambs = grid_jambs(grid, doors["corridor-west-room"])
    assert jambs is not None
    a, b = sorted(jambs)
    assert a == pytest.approx((1.475, 2.025)) and b == pytest.approx((2.525, 2.025))
    # The 0.9 m gap in the wall at x 4.0 to 4.1, y 4.55 to 5.45.
    jambs = grid_jambs(grid, doors["connecting"])
    assert jambs is not None
    low, high = sorted(jambs, key=lambda point: point[1])
    assert low == pytest.approx((4.025, 4.525)) and high == pytest.approx((4.025, 5.475))


def test_a_shut_door_on_a_grid_spans_its_doorway_wall_to_wall(tmp_path):
    plan = load_floorplan(write_scanned_plan(tmp_path))
    grid = walls_of(plan)
    door = next(door for door in plan.doors if door.id == "corridor-west-room")
    assert doorway(plan, door, grid) == grid_jambs(grid, door)  # type: ignore[arg-type]


def test_a_door_in_open_floor_has_no_jambs(tmp_path):
    plan = open_floor_plan(tmp_path)
    grid = walls_of(plan)
    assert grid is not None
    door = next(door for door in plan.doors if door.id == "corridor-east-end")
    assert grid_jambs(grid, door) is None
