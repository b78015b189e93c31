"""A grid drawn from room outlines: the example's image, and D* Lite through its doors."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.dstar_lite import DStarLite
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.rasterise import grid_image, rasterise

EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"
# About the Giraff's base (issue 6).
ROBOT_RADIUS_M = 0.3


def test_the_example_grid_image_is_its_outlines_drawn():
    plan = load_floorplan(EXAMPLE)
    assert plan.grid is not None
    committed = cv2.imread(str(plan.grid.image), cv2.IMREAD_UNCHANGED)
    drawn = rasterise(plan)
    assert np.array_equal(committed, grid_image(drawn))
    assert drawn.origin == tuple(plan.grid.origin[:2])
    assert drawn.resolution == plan.grid.resolution


def cell(grid: OccupancyGrid, plan, room: str) -> tuple[int, int]:
    return grid.cell_of(*plan.rooms[room].at)


def test_dstar_lite_finds_the_way_through_the_doors_and_none_when_one_is_shut():
    plan = load_floorplan(EXAMPLE)
    grid = rasterise(plan).inflated(ROBOT_RADIUS_M)
    planner = DStarLite(grid.blocked(), cell(grid, plan, "dock"), cell(grid, plan, "kitchen"))
    path = planner.plan()
    assert path is not None
    # Through the dock's door, the corridor, the dining room's door and the kitchen's.
    for door in ("dock-corridor", "dining-room-corridor", "kitchen-dining-room"):
        door_at = next(d for d in plan.doors if d.id == door)
        centre = np.array(grid.cell_of(*door_at.at))
        half_width = door_at.width / 2 / grid.resolution
        assert min(np.abs(np.array(p) - centre).max() for p in path) <= half_width
    # The kitchen is reached through the dining room or the east hall: shut both doors,
    # and there is no way.
    kitchen_doors = frozenset({"kitchen-dining-room", "kitchen-east-hall"})
    shut = rasterise(plan, closed=kitchen_doors).inflated(ROBOT_RADIUS_M)
    changes = [((r, c), True) for r, c in zip(*np.nonzero(shut.blocked() & ~grid.blocked()),
                                               strict=True)]  # fmt: skip
    planner.update_cells(changes)
    assert planner.plan() is None
