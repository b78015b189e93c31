"""An Open-RMF level's floor drawn from its walls, doors and floors: its spaces, and a grid.

traffic-editor draws a building's walls and doors as segments between vertices and its
floors as polygons, and RMF builds its simulated world from them. Drawn into a grid,
they say what the lanes alone cannot: where one room ends and the next begins. Two
grids are drawn from them here, alike but for the doors:

- the spaces: with every door shut, each part of the floor that walls and doors bound,
  and that the robot can drive all over, is one space (rmf_spaces.py finds its rooms);
  10 cm cells, as places the robot could stand, each joined to its neighbours and
  knowing how far it is from a wall. A gap the robot cannot pass (a wall stopping short
  of another) parts two spaces as a wall would: the planner would find no way through;
- the grid the robot plans on (§2.6.4), written next to the floor plan: with each door
  of the floor plan open as wide as the door (the others shut), 5 cm cells, walls 0.1 m
  thick as rasterise.py draws outlines, unknown off the floor.

Outside the level's `floors` polygons (less its `holes`) is not floor. A level without
floor polygons is floor up to its walls: the part round the outside that holds no named
vertex is outside the building. A very large level is drawn in coarser cells, so that
its grids stay a size a robot's computer plans on in well under a second.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass
from itertools import chain

import cv2
import numpy as np
from scipy.sparse import csr_array  # type: ignore[import-untyped]
from scipy.sparse.csgraph import connected_components, dijkstra  # type: ignore[import-untyped]

from giraff_console.planning.floorplan import Point
from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.planning.rasterise import MARGIN_M, RESOLUTION_M, WALL_M
from giraff_console.planning.rmf_level import Level, Places
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M

SPACE_CELL_M = 0.1
# The most cells each grid may have: a 100 m by 100 m level keeps 5 cm cells for the
# grid, and one of 70 m by 70 m 10 cm ones for its spaces; an airport terminal's are
# drawn coarser, so that finding its rooms takes a few hundred megabytes, not gigabytes.
MAX_SPACE_CELLS = 500_000
MAX_GRID_CELLS = 4_000_000
# A named vertex on a wall, or just off the floor, is a room at the nearest free floor
# within this distance.
SEAT_REACH_M = 1.0
# How far from a wall the robot's centre must stay to drive there: its radius and the
# planner's margin (route_planner.py). Floor narrower than twice this is no way through.
PASSABLE_M = ROBOT_RADIUS_M + CLEARANCE_M
# How far from a door's line its sides are looked for: a wall's thickness and more.
PROBE_M = 0.6
_SHIFT = 4  # cv2 draws at sixteenths of a cell


@dataclass(frozen=True)
class Frame:
    """Where a grid's cells are in the map frame; row 0 is the top (map_server's way)."""

    origin: Point  # the lower-left corner of the lower-left cell
    resolution: float
    rows: int
    cols: int

    def cell(self, point: Point) -> tuple[int, int] | None:
        row, col = self.row_col(point)
        return (row, col) if 0 <= row < self.rows and 0 <= col < self.cols else None

    def row_col(self, point: Point) -> tuple[int, int]:
        """The row and column `point` is in, were the grid to go on past its edges."""
        col = math.floor((point[0] - self.origin[0]) / self.resolution)
        return self.rows - 1 - math.floor((point[1] - self.origin[1]) / self.resolution), col

    def drawn(self, points: list[Point]) -> np.ndarray:
        """Points as cv2 draws them: x the column, y the row, cell centres at whole
        numbers, in sixteenths."""
        res, (ox, oy) = self.resolution, self.origin
        pixels = [((x - ox) / res - 0.5, self.rows - (y - oy) / res - 0.5) for x, y in points]
        return np.round(np.array(pixels) * (1 << _SHIFT)).astype(np.int32)


@dataclass(frozen=True)
class Floor:
    places: Places  # the free cells of the spaces, doors shut
    frame: Frame  # the spaces' cells
    index: np.ndarray  # (rows, cols): the place of each cell, -1 for a wall or off the floor
    door_sides: dict[int, tuple[int | None, int | None]]  # by door: the place on each side

    def seat(self, point: Point) -> int | None:
        """The place at `point`, or the nearest within SEAT_REACH_M (a vertex on a wall,
        or just off the floor); None if there is none so near."""
        res, (ox, oy) = self.frame.resolution, self.frame.origin
        row, col = self.frame.row_col(point)
        reach = math.ceil(SEAT_REACH_M / res)
        top, left = max(0, row - reach), max(0, col - reach)
        window = self.index[top : max(0, row + reach + 1), left : max(0, col + reach + 1)]
        found = np.argwhere(window >= 0)
        if not found.size:
            return None
        x = ox + (found[:, 1] + left + 0.5) * res
        y = oy + (self.frame.rows - found[:, 0] - top - 0.5) * res
        away = np.hypot(x - point[0], y - point[1])
        best = int(np.argmin(away))
        if away[best] > SEAT_REACH_M:
            return None
        return int(window[found[best, 0], found[best, 1]])

    def on_floor(self, point: Point) -> bool:
        cell = self.frame.cell(point)
        return cell is not None and self.index[cell] >= 0


def draw_floor(level: Level) -> Floor:
    """The level's spaces, from its walls, doors and floors."""
    frame = _frame(level, SPACE_CELL_M, MAX_SPACE_CELLS)
    free = _draw(level, frame) == FREE
    places, index = _places(frame, free)
    return Floor(places, frame, index, _door_sides(level, frame, index))


def draw_grid(level: Level, doors: Collection[int]) -> OccupancyGrid:
    """The grid to plan on, from the level's walls, doors and floors, with the doors in
    `doors` (indices) open: the floor plan's. The others stay shut, as walls: a door the
    plan leaves out (one to outside the floor) leads nowhere the robot may go."""
    frame = _frame(level, RESOLUTION_M, MAX_GRID_CELLS)
    cells = _draw(level, frame, doors)
    return OccupancyGrid(cells, frame.resolution, frame.origin)


def _frame(level: Level, finest: float, most: int) -> Frame:
    """A frame round what the level draws (its walls, floors and doors), with a margin.
    Named vertices and lanes do not widen it: a stray vertex far off the drawing would
    make every cell coarse. A named vertex outside it is off the floor, and told so."""
    ends = [level.points[v] for wall in level.walls for v in wall]
    points = [*ends, *chain(*level.floors), *(p for door in level.doors for p in door.ends)]
    xs, ys = [x for x, _ in points], [y for _, y in points]
    # In whole millimetres, as the floor plan writes them.
    left, bottom = (math.floor((min(xs) - MARGIN_M) * 1000) / 1000,
                    math.floor((min(ys) - MARGIN_M) * 1000) / 1000)  # fmt: skip
    width, height = max(xs) + MARGIN_M - left, max(ys) + MARGIN_M - bottom
    resolution = max(finest, math.ceil(math.sqrt(width * height / most) * 1000) / 1000)
    rows, cols = math.ceil(height / resolution), math.ceil(width / resolution)
    return Frame((left, bottom), resolution, rows, cols)


def _draw(level: Level, frame: Frame, open_doors: Collection[int] = ()) -> np.ndarray:
    """The level in `frame`: FREE floor, OCCUPIED walls and shut doors, UNKNOWN off the
    floor; the doors in `open_doors` (indices) open."""
    cells = np.full((frame.rows, frame.cols), UNKNOWN if level.floors else FREE, np.uint8)
    if level.floors:
        cv2.fillPoly(cells, [frame.drawn(f) for f in level.floors], int(FREE), shift=_SHIFT)
    if level.holes:
        cv2.fillPoly(cells, [frame.drawn(h) for h in level.holes], int(UNKNOWN), shift=_SHIFT)
    thickness = max(1, round(WALL_M / frame.resolution))
    segments = [(level.points[a], level.points[b]) for a, b in level.walls]
    for a, b in segments + [door.ends for door in level.doors]:
        (ax, ay), (bx, by) = frame.drawn([a, b])
        cv2.line(cells, (int(ax), int(ay)), (int(bx), int(by)), int(OCCUPIED), thickness,
                 cv2.LINE_8, _SHIFT)  # fmt: skip
    if not level.floors:
        _outside(level, frame, cells)
    if open_doors:
        # As wide as the door, and through the wall's thickness and a cell more either side.
        half = thickness * frame.resolution / 2 + frame.resolution
        doorways = np.zeros_like(cells)
        for i in sorted(open_doors):
            door = level.doors[i]
            if door.width == 0:
                continue
            (px, py), (qx, qy) = door.ends
            nx, ny = (half * n for n in door.normal)
            corners = [(px + nx, py + ny), (qx + nx, qy + ny), (qx - nx, qy - ny),
                       (px - nx, py - ny)]  # fmt: skip
            cv2.fillPoly(doorways, [frame.drawn(corners)], 1, shift=_SHIFT)
        cells[(doorways > 0) & (cells == OCCUPIED)] = FREE
    return cells


def _outside(level: Level, frame: Frame, cells: np.ndarray) -> None:
    """Without floor polygons: the floor round the edge of the frame that holds no named
    vertex is outside the building, and unknown."""
    _, labels = cv2.connectedComponents((cells == FREE).astype(np.uint8), connectivity=4)
    edge = set(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]).tolist())
    inside = {int(labels[cell]) for named in level.named if (cell := frame.cell(named.at))}
    for label in edge - inside - {0}:
        cells[labels == label] = UNKNOWN


def _places(frame: Frame, free: np.ndarray) -> tuple[Places, np.ndarray]:
    """The free cells as places, each joined to its eight neighbours (diagonally only
    where both cells beside the step are free: never through a wall's corner)."""
    rows = free.shape[0]
    index = np.full(free.shape, -1, np.int64)
    index[free] = np.arange(int(free.sum()))
    res = frame.resolution
    pairs, lengths = [], []
    for a, b, step, also in [
        (index[:, :-1], index[:, 1:], res, None),
        (index[:-1, :], index[1:, :], res, None),
        (index[:-1, :-1], index[1:, 1:], res * math.sqrt(2), free[:-1, 1:] & free[1:, :-1]),
        (index[:-1, 1:], index[1:, :-1], res * math.sqrt(2), free[:-1, :-1] & free[1:, 1:]),
    ]:
        joined = (a >= 0) & (b >= 0)
        if also is not None:
            joined &= also
        pairs.append(np.stack([a[joined], b[joined]]))
        lengths.append(np.full(int(joined.sum()), step))
    ends, length = np.concatenate(pairs, axis=1), np.concatenate(lengths)
    count = int(free.sum())
    links = csr_array(
        (np.concatenate([length, length]),
         (np.concatenate([ends[0], ends[1]]), np.concatenate([ends[1], ends[0]]))),
        shape=(count, count),
    )  # fmt: skip
    cell_rows, cell_cols = np.nonzero(free)
    xy = np.stack([frame.origin[0] + (cell_cols + 0.5) * res,
                   frame.origin[1] + (rows - cell_rows - 0.5) * res], axis=1)  # fmt: skip
    # To the nearest cell that is not free, off the frame's edge included.
    padded = np.pad(free, 1).astype(np.uint8)
    away = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    clearance = (away[free] - 0.5) * res
    space = _passable_spaces(links, clearance >= PASSABLE_M)
    return Places(xy, links, space, clearance, res), index


def _passable_spaces(links: csr_array, clear: np.ndarray) -> np.ndarray:
    """The space of each place: the places the robot can stand on (`clear`) that join
    one another are one space, and each other place is in the space of the clear place
    nearest it along the floor (a room's corners, a doorway's sides, a slit's two halves).
    A part of the floor with no clear place at all is a space of its own."""
    _, space = connected_components(links, directed=False)
    inside = np.flatnonzero(clear)
    if inside.size:
        count, label = connected_components(links[inside, :][:, inside], directed=False)
        _, _, sources = dijkstra(links, indices=inside, min_only=True, return_predecessors=True)
        reached = sources >= 0
        where = np.full(len(space), -1, np.int64)
        where[inside] = np.arange(inside.size)
        space = space + count  # apart from the clear spaces' numbers
        space[reached] = label[where[sources[reached]]]
    return np.unique(space, return_inverse=True)[1].astype(np.int64)


def _door_sides(
    level: Level, frame: Frame, index: np.ndarray
) -> dict[int, tuple[int | None, int | None]]:
    """The place just off each door on each side (its left, from its first end to its
    second, then its right); None for a side with no floor within PROBE_M."""
    sides: dict[int, tuple[int | None, int | None]] = {}
    res = frame.resolution
    for i, door in enumerate(level.doors):
        if door.width == 0:
            sides[i] = (None, None)
            continue
        nx, ny = door.normal
        cx, cy = door.centre
        found: list[int | None] = []
        for sign in (1.0, -1.0):
            place = None
            for away in np.arange(res / 2, PROBE_M + 1e-9, res / 2):
                cell = frame.cell((cx + sign * nx * away, cy + sign * ny * away))
                if cell is not None and index[cell] >= 0:
                    place = int(index[cell])
                    break
            found.append(place)
        sides[i] = (found[0], found[1])
    return sides
