"""Occupancy grids: a room as a bitmap of free, occupied and unexplored cells (§2.6.4).

The thesis proposes that each room be held as a grid whose squares are "coloured" by
whether they are thought to hold an obstacle, to be traversable, or not yet explored,
updated as the robot moves and handed to D* Lite for replanning. This module is that
grid, with the conventions of ROS map_server so that maps drawn for ROS load unchanged:

- The image's row 0 is the top of the map, so map y grows upwards while rows grow
  downwards; `origin` is the map-frame position of the lower-left corner of the
  lower-left cell.
- Pixels are read as probabilities of occupancy by map_server's trinary rule.

The planner works on cells, so the robot is shrunk to a point and the obstacles grown by
its radius instead (`inflated`). Unknown space is blocked by default: the Giraff moves
among frail people, and a plan through a room it has not seen could lead it over
someone's feet.
"""

from __future__ import annotations

from collections.abc import Mapping

import cv2
import numpy as np

FREE = np.uint8(0)
OCCUPIED = np.uint8(100)
UNKNOWN = np.uint8(255)  # ROS's -1, as an unsigned byte

Cell = tuple[int, int]


class OccupancyGrid:
    """Cells of FREE, OCCUPIED or UNKNOWN, `resolution` metres on a side, placed in the
    map frame by `origin` (the x, y of the lower-left cell's lower-left corner)."""

    def __init__(
        self,
        cells: np.ndarray,
        resolution: float,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        cells = np.asarray(cells, dtype=np.uint8)
        if cells.ndim != 2:
            raise ValueError(f"an occupancy grid is two-dimensional, not {cells.shape}")
        if not np.isin(cells, (FREE, OCCUPIED, UNKNOWN)).all():
            raise ValueError("cells must be FREE, OCCUPIED or UNKNOWN")
        if resolution <= 0:
            raise ValueError(f"resolution must be positive, not {resolution}")
        self.cells = cells
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))

    @classmethod
    def from_image(
        cls,
        pixels: np.ndarray,
        resolution: float,
        origin: tuple[float, float] = (0.0, 0.0),
        negate: int = 0,
        occupied_thresh: float = 0.65,
        free_thresh: float = 0.196,
    ) -> OccupancyGrid:
        """Read a map image as map_server's trinary mode does: a colour pixel is the mean
        of its colour channels (alpha ignored), its occupancy is (255 - value) / 255, or
        value / 255 with `negate`, and it is occupied above `occupied_thresh`, free below
        `free_thresh`, and unknown in between. A 16-bit image's values are out of 65535,
        not 255, as nav2's map_server reads them."""
        pixels = np.asarray(pixels)
        top = float(np.iinfo(pixels.dtype).max) if pixels.dtype.kind in "ui" else 255.0
        if pixels.ndim == 2 and pixels.dtype in (np.uint8, np.uint16):
            # A grey image, as maps are: each value's cell worked out once, by the same
            # sums, then looked up for every pixel (the example's 450,000 pixels in a
            # fifth of the time; read twice as the console starts, issue 26, item 6).
            return cls(_trinary(np.arange(int(top) + 1), top, negate, occupied_thresh,
                                free_thresh)[pixels], resolution, origin)  # fmt: skip
        if pixels.ndim == 3:
            channels = 3 if pixels.shape[2] >= 3 else 1
            value = pixels[:, :, :channels].astype(np.float64).mean(axis=2)
        else:
            value = pixels.astype(np.float64)
        return cls(_trinary(value, top, negate, occupied_thresh, free_thresh), resolution, origin)

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns)."""
        return self.cells.shape

    def cell_of(self, x: float, y: float) -> Cell:
        """The (row, col) of the cell holding map point (x, y). Raises ValueError off the
        map: a negative index would silently wrap round to the far side of the array."""
        rows, cols = self.cells.shape
        col = int(np.floor((x - self.origin[0]) / self.resolution))
        up = int(np.floor((y - self.origin[1]) / self.resolution))
        row = rows - 1 - up
        if not (0 <= row < rows and 0 <= col < cols):
            raise ValueError(f"({x}, {y}) is off the map")
        return row, col

    def centre_of(self, row: int, col: int) -> tuple[float, float]:
        """The map-frame (x, y) of the centre of cell (row, col)."""
        rows = self.cells.shape[0]
        x = self.origin[0] + (col + 0.5) * self.resolution
        y = self.origin[1] + (rows - row - 0.5) * self.resolution
        return x, y

    def occupied_around(self, x: float, y: float,
                        reach: float) -> tuple[np.ndarray, float, float]:  # fmt: skip
        """The occupied cells within `reach` of map point (x, y) each way (clipped to the
        map; empty off it), and the map (left, top) of the window's top-left corner."""
        rows, cols = self.cells.shape
        res = self.resolution
        first = max(0, int(np.floor((x - reach - self.origin[0]) / res)))
        last = min(cols, int(np.floor((x + reach - self.origin[0]) / res)) + 1)
        top = max(0, rows - 1 - int(np.floor((y + reach - self.origin[1]) / res)))
        bottom = min(rows, rows - int(np.floor((y - reach - self.origin[1]) / res)))
        occupied = self.cells[top : max(top, bottom), first : max(first, last)] == OCCUPIED
        return occupied, self.origin[0] + first * res, self.origin[1] + (rows - top) * res

    def blocked(self, unknown_blocks: bool = True) -> np.ndarray:
        """A boolean array of the cells a planner must not enter."""
        if unknown_blocks:
            return self.cells != FREE
        return self.cells == OCCUPIED

    def inflated(self, radius_m: float, unknown_blocks: bool = True) -> OccupancyGrid:
        """A new grid where every free cell whose centre lies within `radius_m` of an
        obstacle cell's centre is occupied, so that a point robot on the free cells keeps
        a robot of that radius off the obstacles.

        With `unknown_blocks`, unknown cells count as obstacles and are grown too, which
        keeps the robot a radius away from the edge of what it has seen; they stay
        UNKNOWN themselves. Without it, they are neither grown nor changed.
        """
        if radius_m < 0:
            raise ValueError(f"radius must not be negative, not {radius_m}")
        seeds = self.blocked(unknown_blocks).astype(np.uint8)
        reach = radius_m / self.resolution
        k = int(np.floor(reach))
        # A true Euclidean disc, rather than cv2.getStructuringElement(MORPH_ELLIPSE),
        # which is a digitised ellipse that overshoots the radius at small sizes (its 5x5
        # kernel includes cells sqrt(5) away for a radius of 2).
        dy, dx = np.mgrid[-k : k + 1, -k : k + 1]
        disc = (dx * dx + dy * dy <= reach * reach + 1e-9).astype(np.uint8)
        grown = cv2.dilate(seeds, disc, borderType=cv2.BORDER_CONSTANT, borderValue=0)
        cells = self.cells.copy()
        cells[(grown > 0) & (cells == FREE)] = OCCUPIED
        return OccupancyGrid(cells, self.resolution, self.origin)

    def set_cells(
        self, changes: Mapping[Cell, int], unknown_blocks: bool = True
    ) -> list[tuple[Cell, bool]]:
        """Set cells in place, as a sensor sweep reports them, and return the cells whose
        traversability changed as (cell, now blocked) pairs, ready for
        `DStarLite.update_cells`."""
        rows, cols = self.cells.shape
        for (row, col), state in changes.items():  # all or nothing
            if not (0 <= row < rows and 0 <= col < cols):
                raise ValueError(f"({row}, {col}) is off the grid")
            if state not in (FREE, OCCUPIED, UNKNOWN):
                raise ValueError(f"{state} is not FREE, OCCUPIED or UNKNOWN")
        changed = []
        for (row, col), state in changes.items():
            before = self._blocks(self.cells[row, col], unknown_blocks)
            self.cells[row, col] = state
            after = self._blocks(state, unknown_blocks)
            if after != before:
                changed.append(((row, col), after))
        return changed

    @staticmethod
    def _blocks(state: int, unknown_blocks: bool) -> bool:
        return state == OCCUPIED or (unknown_blocks and state == UNKNOWN)


def blocked_changes(before: np.ndarray, after: np.ndarray) -> list[tuple[Cell, bool]]:
    """The cells that differ between two blocked arrays, as (cell, now blocked) pairs:
    what to tell D* Lite after re-inflating a grid that a sensor sweep has changed."""
    if before.shape != after.shape:
        raise ValueError(f"grids differ in shape: {before.shape} and {after.shape}")
    return [((int(r), int(c)), bool(after[r, c])) for r, c in np.argwhere(before != after)]


def _trinary(value: np.ndarray, top: float, negate: int, occupied_thresh: float,
             free_thresh: float) -> np.ndarray:  # fmt: skip
    """The cells for pixel values out of `top`, as map_server's trinary mode reads them
    (OccupancyGrid.from_image)."""
    value = value.astype(np.float64)
    occupancy = value / top if negate else (top - value) / top
    cells = np.full(value.shape, UNKNOWN, dtype=np.uint8)
    cells[occupancy > occupied_thresh] = OCCUPIED
    cells[occupancy < free_thresh] = FREE
    return cells
