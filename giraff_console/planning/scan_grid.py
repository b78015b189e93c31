"""A scanned map's grid as `floorplan rooms` finds rooms on it and its plan plans on it.

A SLAM map is rarely the building alone. Mapping packages save a fixed canvas (4000 by
4000 cells is a common default) of which the building is a corner, the rest unknown;
segmenting all of it took 17 s and 580 MB for a 4000-cell map and 129 s and 3 GB for a
10000-cell one. So the grid is cropped to the floor and `CROP_MARGIN_M` round it: every
cell beyond that is wall or unknown, which neither the rooms nor the route planner can
use, and the room points and doors are placed by the crop's own origin.

And a scan is speckled: single cells a laser got wrong, a person walking past, the legs
of tables and chairs. The route planner grows every occupied or unknown cell by the
robot's radius and its clearance (route_planner.py), so a speck in a doorway shuts it,
and half a per cent of speckle shuts most of a building's rooms off from the rest. Holes
in the floor up to `SPECK_M2` and `SPECK_SIDE_M` across are cleared, in the grid the
rooms are found on and in the grid written with the plan alike, so that the plan's rooms
are the ones its planner can reach. The robot's range finder sees the legs again as it
drives (legs.py), as it sees anything the map does not show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import GridSpec
from giraff_console.planning.grid import FREE, OccupancyGrid
from giraff_console.planning.ros_map import read_grid_image, read_ros_map

# Holes in the free space up to this size are cleared: single cells a scan got wrong, and
# the legs of tables and chairs (a 7 cm leg is 0.005 m^2).
SPECK_M2 = 0.05
# ... and no longer than this either way: a glass screen or a bench's edge is as small in
# area as a table leg, but long, and the robot must not be planned through it.
SPECK_SIDE_M = 0.2
# The crop keeps this much round the floor: its walls, and what lies just beyond them.
CROP_MARGIN_M = 1.0
# Rows of the image read into the grid at a time: OccupancyGrid.from_image holds the
# pixels it reads as float64 twice over, 16 bytes a pixel, 1.6 GB for a 10000-cell map.
BAND_ROWS = 512


@dataclass(frozen=True)
class Scan:
    spec: GridSpec
    grid: OccupancyGrid  # the map's grid, cropped to its floor and CROP_MARGIN_M round it
    cropped: bool  # whether the crop left anything out
    notes: tuple[str, ...]  # what of the map is not used, for the operator to know


@dataclass(frozen=True)
class CleanGrid:
    grid: OccupancyGrid  # the grid with its specks cleared
    specks: int  # holes cleared
    speck_cells: int  # the cells they held


def read_scan(path: str | Path) -> Scan:
    """The ROS map_server map at `path` and its grid, cropped; FloorPlanError for a bad
    map. The whole grid is never an OccupancyGrid: checking its cells takes 8 bytes a
    cell, 800 MB for a 10000-cell map."""
    spec = read_ros_map(path)
    pixels = read_grid_image(spec.image)
    height, width = pixels.shape[:2]
    cells = np.empty((height, width), dtype=np.uint8)
    free_rows = np.zeros(height, dtype=bool)
    free_cols = np.zeros(width, dtype=bool)
    for top in range(0, height, BAND_ROWS):
        band = OccupancyGrid.from_image(pixels[top : top + BAND_ROWS], spec.resolution,
                                        (0.0, 0.0), spec.negate, spec.occupied_thresh,
                                        spec.free_thresh)  # fmt: skip
        cells[top : top + BAND_ROWS] = band.cells
        free = band.cells == FREE
        free_rows[top : top + BAND_ROWS] = free.any(axis=1)
        free_cols |= free.any(axis=0)
    notes: tuple[str, ...] = ()
    if spec.origin[2] != 0:
        # map_server's documentation: "many parts of the system currently ignore yaw".
        notes = (f"the yaw in origin ({spec.origin[2]:g}) is not applied: the map is read "
                 "unrotated, as most ROS tools read it",)  # fmt: skip
    rows, cols = np.flatnonzero(free_rows), np.flatnonzero(free_cols)
    if not len(rows):
        grid = OccupancyGrid(cells, spec.resolution, spec.origin[:2])
        return Scan(spec, grid, False, notes)
    margin = math.ceil(CROP_MARGIN_M / spec.resolution)
    top, bottom = max(0, rows[0] - margin), min(height, rows[-1] + 1 + margin)
    left, right = max(0, cols[0] - margin), min(width, cols[-1] + 1 + margin)
    # The origin is the lower-left corner, and rows count down from the top.
    origin = (spec.origin[0] + left * spec.resolution,
              spec.origin[1] + (height - bottom) * spec.resolution)  # fmt: skip
    grid = OccupancyGrid(cells[top:bottom, left:right].copy(), spec.resolution, origin)
    return Scan(spec, grid, grid.shape != (height, width), notes)


def clean_grid(grid: OccupancyGrid) -> CleanGrid:
    """`grid` with the holes in its free space up to SPECK_M2 made free."""
    cells = grid.cells.copy()
    holes = _specks(cells == FREE, round(SPECK_M2 / grid.resolution**2),
                    max(1, math.floor(SPECK_SIDE_M / grid.resolution + 1e-9)))  # fmt: skip
    cells[holes > 0] = FREE
    return CleanGrid(OccupancyGrid(cells, grid.resolution, grid.origin), int(holes.max()),
                     int(np.count_nonzero(holes)))  # fmt: skip


def _specks(free: np.ndarray, speck_cells: int, speck_side: int) -> np.ndarray:
    """The holes in `free` of at most `speck_cells` cells and `speck_side` cells either
    way, numbered from 1 (0 elsewhere): blobs of other cells with free cells all round,
    none on the grid's edge."""
    count, blobs, stats, _ = cv2.connectedComponentsWithStats((~free).astype(np.uint8),
                                                              connectivity=8)  # fmt: skip
    rows, cols = free.shape
    left, top = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    right = left + stats[:, cv2.CC_STAT_WIDTH]
    bottom = top + stats[:, cv2.CC_STAT_HEIGHT]
    inside = (left > 0) & (top > 0) & (right < cols) & (bottom < rows)
    width, height = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    small = (width <= speck_side) & (height <= speck_side)
    speck = inside & small & (stats[:, cv2.CC_STAT_AREA] <= speck_cells)
    speck[0] = False  # label 0 is the free space itself
    number = np.zeros(count, dtype=np.int32)
    number[speck] = np.arange(1, np.count_nonzero(speck) + 1)
    return number[blobs]
