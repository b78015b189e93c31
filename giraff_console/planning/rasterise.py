"""An occupancy grid drawn from a floor plan's room outlines (§2.6.2).

A floor plan without a surveyed map still says where the walls are: every edge of a
room's outline is one. The grid is free inside the outlines, occupied along their edges,
with a gap the door's width at every open door, and unknown outside every room, which
the planner treats as blocked. The example care home's grid image is drawn this way.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.planning.floorplan import FloorPlan
from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid

RESOLUTION_M = 0.05
WALL_M = 0.1
MARGIN_M = 0.5
# map_server's usual shades: white free, black occupied, grey unknown.
SHADES = {FREE: 254, OCCUPIED: 0, UNKNOWN: 205}


def rasterise(plan: FloorPlan, resolution: float = RESOLUTION_M, wall: float = WALL_M,
              closed: frozenset[str] = frozenset()) -> OccupancyGrid:  # fmt: skip
    """The plan's outlines as a grid; doors in `closed`, and doors the plan has shut,
    stay walls. ValueError if no room has an outline."""
    outlines = [room.outline for room in plan.rooms.values() if room.outline]
    if not outlines:
        raise ValueError(f"{plan.path}: no room has an outline to draw a grid from")
    xs = [x for outline in outlines for x, _ in outline]
    ys = [y for outline in outlines for _, y in outline]
    origin = (min(xs) - MARGIN_M, min(ys) - MARGIN_M)
    cols = math.ceil((max(xs) + MARGIN_M - origin[0]) / resolution)
    rows = math.ceil((max(ys) + MARGIN_M - origin[1]) / resolution)
    cells = np.full((rows, cols), UNKNOWN, dtype=np.uint8)

    def pixel(x: float, y: float) -> tuple[int, int]:
        # Column from x; row 0 at the top of the map (map_server's image convention).
        return round((x - origin[0]) / resolution), round(rows - (y - origin[1]) / resolution)

    polygons = [np.array([pixel(*point) for point in outline], np.int32) for outline in outlines]
    cv2.fillPoly(cells, polygons, int(FREE))
    thickness = max(1, round(wall / resolution))
    cv2.polylines(cells, polygons, isClosed=True, color=int(OCCUPIED), thickness=thickness)
    for door in plan.doors:
        if door.open and door.id not in closed:
            radius = max(1, round(door.width / 2 / resolution))
            cv2.circle(cells, pixel(*door.at), radius, int(FREE), thickness=-1)
    return OccupancyGrid(cells, resolution, origin)


def grid_image(grid: OccupancyGrid) -> np.ndarray:
    """The grid as a map_server greyscale image (write it as PGM or PNG)."""
    image = np.empty(grid.cells.shape, dtype=np.uint8)
    for state, shade in SHADES.items():
        image[grid.cells == state] = shade
    return image
