"""Legs across one room on the occupancy grid: ways between two points (§2.6.4).

The room graph (§2.6.2) says which doors to pass; a leg is the way from one of those
points to the next, across the room they share. The thesis would hold "each room ...
internally represented as a bitmap" and run D* on it, so each leg plans on a window of
the grid around its room's outline rather than on the whole building: a corridor's
window is a few tens of thousands of cells where the care home has half a million.

Measuring a leg (the room graph asks for the lengths of the legs its routes might take)
uses grid_search.py's numpy search, and a leg whose straight line is clear is that line
with no search at all. The leg the robot is driving keeps a D* Lite planner (`Leg`),
whose first plan is that same search and whose replans repair it as obstacles are seen:
there its incremental replans beat any search from scratch. Measured and driven, a leg
is the same way.

The planner's 8-connected staircase is then shortened by line of sight: every corner the
robot could skip without its disc touching an obstacle (the grid is inflated by its
radius) is dropped, so that what is driven, and what a leg measures, is a polyline of
few corners. Shortening runs on the same inflated grid, so it never cuts a corner the
planner went round.

The range finder adds to the grid what the plan does not show (§2.1, §6), and takes it
away again: the thesis's grid squares are "coloured" by what is thought to be in them
and updated as the robot moves (§2.6.4), so a box that has gone is not planned round
for ever. A beam that passes through a square where something was seen clears it, as a
laser's free space clears a ROS costmap; the plan's own walls are never cleared.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np

from giraff_console.planning.dstar_lite import DStarLite
from giraff_console.planning.floorplan import FloorPlan, Point
from giraff_console.planning.grid import Cell, OccupancyGrid
from giraff_console.planning.grid_search import shortest_path

# How far round a room's outline its window reaches: its doors' far sides, and the walls.
WINDOW_MARGIN_M = 0.6
# Without an outline, how far round the two ends the window reaches.
OPEN_MARGIN_M = 3.0
# An end that falls on a blocked cell (a robot close to a wall) starts from the nearest
# free cell within this distance.
NEAREST_FREE_M = 0.6
# A beam clears the cells it passed through up to this many cells short of what it hit:
# a diagonal cell's width (sqrt 2), so that it never clears the square the hit is in.
HIT_MARGIN_CELLS = 1.5


class Leg:
    """The way between two points within a window of the grid, replanned incrementally
    as cells change (`update`) and the robot moves along it (`move_to`)."""

    def __init__(self, grid: OccupancyGrid, blocked: np.ndarray, start: Point, goal: Point,
                 window: tuple[int, int, int, int]) -> None:  # fmt: skip
        self.grid, self.start, self.goal = grid, start, goal
        top, left, bottom, right = window
        self.offset = (top, left)
        view = blocked[top:bottom, left:right]
        reach = max(1, round(NEAREST_FREE_M / grid.resolution))
        self._start_cell = free_near(view, self._local(start), reach)
        self._goal_cell = free_near(view, self._local(goal), reach)
        self._planner: DStarLite | None = None
        if self._start_cell is not None and self._goal_cell is not None:
            # D* Lite's first plan is grid_search's (it starts from that search's costs);
            # its replans repair them as cells change and the robot moves.
            self._planner = DStarLite(view, self._start_cell, self._goal_cell)

    def cells(self) -> list[Cell] | None:
        """The grid cells of the way, in whole-grid (row, col); None if there is none."""
        if self._planner is None:
            return None
        local = self._planner.plan()
        if local is None:
            return None
        top, left = self.offset
        return [(row + top, col + left) for row, col in local]

    def update(self, changes: list[tuple[Cell, bool]]) -> None:
        """Cells of the whole grid became blocked (True) or free; those in the window
        are passed to D* Lite, which repairs its search on the next `cells()`."""
        if self._planner is None:
            return
        top, left = self.offset
        rows, cols = self._planner.shape
        inside = [
            ((row - top, col - left), now)
            for (row, col), now in changes
            if 0 <= row - top < rows and 0 <= col - left < cols
        ]
        self._planner.update_cells(inside)

    def move_to(self, point: Point) -> None:
        """The robot is now at `point`: plan on from there."""
        self.start = point
        if self._planner is None:
            return
        cell = self._local(point)
        rows, cols = self._planner.shape
        if 0 <= cell[0] < rows and 0 <= cell[1] < cols:
            self._planner.move_to(cell)

    def _local(self, point: Point) -> Cell:
        row, col = self.grid.cell_of(*point)
        return row - self.offset[0], col - self.offset[1]


def free_near(view: np.ndarray, cell: Cell, reach: int) -> Cell | None:
    """`cell` if it is in the window and free, else the nearest free cell within
    `reach` cells; None if there is none."""
    rows, cols = view.shape
    row, col = cell
    if not (0 <= row < rows and 0 <= col < cols):
        return None
    if not view[row, col]:
        return cell
    top, left = max(0, row - reach), max(0, col - reach)
    patch = view[top : row + reach + 1, left : col + reach + 1]
    free = np.argwhere(~patch)
    if free.size == 0:
        return None
    distance = np.hypot(free[:, 0] + top - row, free[:, 1] + left - col)
    best = free[int(np.argmin(distance))]
    if distance.min() > reach:
        return None
    return int(best[0] + top), int(best[1] + left)


class GridLegs:
    """Legs on a floor plan's grid inflated by the robot's radius; also the room graph's
    `leg_length`."""

    def __init__(self, plan: FloorPlan, inflated: OccupancyGrid) -> None:
        self.plan = plan
        self.grid = inflated
        self.blocked = inflated.blocked()
        # The plan's own cells: what sensing may block more of, and never clear.
        self._plan_blocked = self.blocked.copy()
        # What sensing saw, one point per cell it fell in: the evidence each blocked
        # disc stands on, so that a disc can be taken away when its cell is seen clear.
        self.sensed: dict[Cell, Point] = {}
        self._sensed_cells = np.zeros_like(self.blocked)
        # How far each sensed point's disc reaches: a contact's reaches further than a
        # range finder's hit (path_mission.py's FELT_EXTENT_M), and freeing it by the
        # smaller left its outer ring blocked for good, with nothing sensed to clear it:
        # a doorway stayed shut for every mission after (issue 25).
        self._radii: dict[Cell, float] = {}
        # The points of each room without an outline, round which its legs plan.
        self._extent = {room.id: [room.at] for room in plan.rooms.values()}
        for door in plan.doors:
            for room_id in door.between:
                self._extent[room_id].append(door.at)
        # Ways found so far: the room graph measures a leg, then the route drives it.
        self._paths: dict[tuple[Point, Point, str | None], list[Point] | None] = {}

    def block(self, points: list[Point], radius: float) -> list[tuple[Cell, bool]]:
        """Obstacles sensed at `points`: the free cells within `radius` of each (the
        robot's, as the grid's inflation) become blocked. Returns the cells that changed,
        as (cell, True) pairs for `Leg.update`; the ways found before are forgotten.

        A point in a cell already sensed adds nothing: its disc is that cell's disc to
        within a cell, and a box seen at every tick would otherwise cost its discs again
        at every tick."""
        changes = []
        for x, y in points:
            try:
                cell = self.grid.cell_of(x, y)
            except ValueError:
                continue  # off the map: nothing to plan round
            if self._sensed_cells[cell]:
                continue
            self.sensed[cell] = (x, y)
            self._sensed_cells[cell] = True
            self._radii[cell] = radius
            rows, cols, near = self._disc(cell, (x, y), radius)
            view = self.blocked[rows, cols]
            new = near & ~view
            view |= near
            top, left = rows.start, cols.start
            changes += [((int(r) + top, int(c) + left), True) for r, c in np.argwhere(new)]
        if changes:
            self._paths.clear()
        return changes

    def see_through(self, origin: Point, ends: list[Point], hits: list[bool],
                    radius: float) -> list[tuple[Cell, bool]]:  # fmt: skip
        """The range finder looked from `origin` along beams to `ends`: what sensing had
        seen in the cells on the way is gone (beams that `hits` something stop short of
        its cell). Every cell then more than `radius` from what is still sensed, and
        not blocked by the plan, is free again. Returns the cells freed, as (cell,
        False) pairs for `Leg.update`; the ways found before are forgotten."""
        if not self.sensed or not ends:
            return []
        seen = self._cells_along(origin, np.asarray(ends, dtype=float), np.asarray(hits))
        seen = seen[self._sensed_cells.ravel()[seen]]
        if not seen.size:
            return []  # nearly every sweep: nothing sensed before lies on a beam
        gone = np.stack(np.divmod(np.unique(seen), self.blocked.shape[1]), axis=1)
        reach = radius
        for row, col in gone.tolist():
            del self.sensed[(row, col)]
            self._sensed_cells[row, col] = False
            reach = max(reach, self._radii.pop((row, col), radius))
        changes = self._free_round(gone, reach)
        if changes:
            self._paths.clear()
        return changes

    def unblock(self, points: list[Point], radius: float) -> list[tuple[Cell, bool]]:
        """What was sensed at `points` is no longer believed (a contact a mission put
        there, path_mission.py): their cells are forgotten and freed as see_through
        frees them. Returns the cells freed, as (cell, False) pairs."""
        gone, reach = [], radius
        for x, y in points:
            try:
                cell = self.grid.cell_of(x, y)
            except ValueError:
                continue
            if self.sensed.pop(cell, None) is not None:
                self._sensed_cells[cell] = False
                reach = max(reach, self._radii.pop(cell, radius))
                gone.append(cell)
        if not gone:
            return []
        changes = self._free_round(np.array(gone), reach)
        if changes:
            self._paths.clear()
        return changes

    def forget_sensed(self) -> bool:
        """Forget all that sensing blocked: the plan's own cells only. True if there was
        anything to forget."""
        if not self.sensed:
            return False
        self.sensed.clear()
        self._radii.clear()
        self._sensed_cells[:] = False
        self.blocked[...] = self._plan_blocked
        self._paths.clear()
        return True

    def _disc(self, cell: Cell, point: Point, radius: float) -> tuple[slice, slice, np.ndarray]:
        """The window of cells round `cell` that a disc of `radius` at `point` can reach,
        and which of them it covers (their centres within `radius` of `point`)."""
        grid, (rows, cols) = self.grid, self.blocked.shape
        reach = math.ceil(radius / grid.resolution)
        row, col = cell
        r = slice(max(0, row - reach), min(rows, row + reach + 1))
        c = slice(max(0, col - reach), min(cols, col + reach + 1))
        x, y = self._centres(r, c)
        return r, c, np.hypot(x - point[0], y - point[1]) <= radius

    def _centres(self, rows: slice, cols: slice) -> tuple[np.ndarray, np.ndarray]:
        """The map x (a row) and y (a column) of the centres of a window's cells."""
        grid, height = self.grid, self.blocked.shape[0]
        x = grid.origin[0] + (np.arange(cols.start, cols.stop) + 0.5) * grid.resolution
        y = grid.origin[1] + (height - np.arange(rows.start, rows.stop) - 0.5) * grid.resolution
        return x[None, :], y[:, None]

    def _cells_along(self, origin: Point, ends: np.ndarray, hits: np.ndarray) -> np.ndarray:
        """The cells the beams cross within the grid, as indices into the flattened
        grid, sampled every half cell (a sliver missed is cleared by the next sweep)."""
        grid = self.grid
        step = grid.resolution / 2
        offset = ends - np.asarray(origin)
        length = np.hypot(offset[:, 0], offset[:, 1])
        reach = np.where(hits, length - HIT_MARGIN_CELLS * grid.resolution, length)
        t = np.arange(0.0, max(0.0, float(reach.max())) + step / 2, step)
        along = t[None, :] <= reach[:, None]  # (beams, samples)
        unit = offset / np.maximum(length, 1e-12)[:, None]
        x = (origin[0] - grid.origin[0]) + unit[:, :1] * t[None, :]
        y = (origin[1] - grid.origin[1]) + unit[:, 1:] * t[None, :]
        col = np.floor(x[along] / grid.resolution).astype(np.int64)
        up = np.floor(y[along] / grid.resolution).astype(np.int64)
        rows, cols = self.blocked.shape
        inside = (col >= 0) & (col < cols) & (up >= 0) & (up < rows)
        return (rows - 1 - up[inside]) * cols + col[inside]

    def _free_round(self, gone: np.ndarray, radius: float) -> list[tuple[Cell, bool]]:
        """Free the cells within `radius` of the sensed cells `gone` that no sensed point
        left keeps blocked (within its own disc), and that the plan does not block."""
        grid, (rows, cols) = self.grid, self.blocked.shape
        reach = math.ceil(radius / grid.resolution)
        (top, left), (bottom, right) = gone.min(axis=0), gone.max(axis=0)
        window = (slice(max(0, top - reach), min(rows, bottom + reach + 1)),
                  slice(max(0, left - reach), min(cols, right + reach + 1)))  # fmt: skip
        candidates = self.blocked[window] & ~self._plan_blocked[window]
        if not candidates.any():
            return []
        # What is still sensed within reach of the window keeps its discs.
        reach = math.ceil(max([radius, *self._radii.values()]) / grid.resolution)
        top, left = max(0, window[0].start - reach), max(0, window[1].start - reach)
        around = self._sensed_cells[top : window[0].stop + reach, left : window[1].stop + reach]
        kept = np.argwhere(around) + np.array([top, left])
        points = np.array([self.sensed[(r, c)] for r, c in kept.tolist()]).reshape(-1, 2)
        radii = np.array([self._radii[(r, c)] for r, c in kept.tolist()], dtype=float)
        x, y = self._centres(*window)
        at = np.argwhere(candidates)
        cx, cy = x[0, at[:, 1]], y[at[:, 0], 0]
        near = np.hypot(cx[:, None] - points[None, :, 0], cy[:, None] - points[None, :, 1])
        free = at[~(near <= radii[None, :]).any(axis=1)]
        free += (window[0].start, window[1].start)
        self.blocked[free[:, 0], free[:, 1]] = False
        return [((r, c), False) for r, c in free.tolist()]

    def leg(self, a: Point, b: Point, room_id: str | None) -> Leg:
        return Leg(self.grid, self.blocked, a, b, self.window(a, b, room_id))

    def path(self, a: Point, b: Point, room_id: str | None) -> list[Point] | None:
        """The way from a to b across the room, shortened by line of sight: the
        straight line when it is clear, else grid_search's way, shortened."""
        key = (a, b, room_id)
        if key not in self._paths:
            self._paths[key] = [a, b] if self.clear(a, b) else self._searched(a, b, room_id)
        return self._paths[key]

    def points(self, leg: Leg) -> list[Point] | None:
        """A leg's way as map points from its start to its goal, shortened."""
        return self._shortened(leg.cells(), leg.start, leg.goal)

    def _searched(self, a: Point, b: Point, room_id: str | None) -> list[Point] | None:
        """The way of grid_search, which finds what a Leg's first plan finds (D* Lite
        starts from its costs) without keeping a planner for replans."""
        top, left, bottom, right = self.window(a, b, room_id)
        view = self.blocked[top:bottom, left:right]
        reach = max(1, round(NEAREST_FREE_M / self.grid.resolution))
        ends = []
        for point in (a, b):
            row, col = self.grid.cell_of(*point)
            ends.append(free_near(view, (row - top, col - left), reach))
        start, goal = ends
        if start is None or goal is None:
            return None
        found = shortest_path(view, start, goal)
        if found is None:
            return None
        return self._shortened([(row + top, col + left) for row, col in found[1]], a, b)

    def _shortened(self, cells: list[Cell] | None, a: Point, b: Point) -> list[Point] | None:
        if cells is None:
            return None
        corners = [self.grid.centre_of(row, col) for row, col in _turns(cells)[1:-1]]
        return self.shorten([a, *corners, b])

    def length(self, a: Point, b: Point, room_id: str) -> float | None:
        """The length of the way from a to b across `room_id`, or None if there is none."""
        points = self.path(a, b, room_id)
        return None if points is None else polyline_length(points)

    def window(self, a: Point, b: Point, room_id: str | None) -> tuple[int, int, int, int]:
        """(top, left, bottom, right) cells of the grid round the room, and a and b."""
        xs, ys = [a[0], b[0]], [a[1], b[1]]
        room = self.plan.rooms.get(room_id) if room_id is not None else None
        margin = OPEN_MARGIN_M
        if room is not None and room.outline:
            xs += [x for x, _ in room.outline]
            ys += [y for _, y in room.outline]
            margin = WINDOW_MARGIN_M
        elif room is not None:
            # Without an outline, the box round the room's point and doors: the same
            # window for every leg of the room, so that a way one leg finds through a
            # door, the leg going straight on finds too (room_graph.py counts on it).
            xs += [x for x, _ in self._extent[room.id]]
            ys += [y for _, y in self._extent[room.id]]
        grid = self.grid
        rows, cols = grid.shape
        x0, y0 = grid.origin
        step = grid.resolution
        left = max(0, math.floor((min(xs) - margin - x0) / step))
        right = min(cols, math.ceil((max(xs) + margin - x0) / step) + 1)
        top = max(0, rows - 1 - math.floor((max(ys) + margin - y0) / step))
        bottom = min(rows, rows - math.floor((min(ys) - margin - y0) / step))
        return top, left, bottom, right

    def clear(self, a: Point, b: Point) -> bool:
        """Whether the straight line from a to b crosses only free cells.

        The line is sampled every quarter cell, which finds every cell it crosses by
        more than a sliver; the inflation's margin covers the slivers. Where two samples
        in a row step diagonally (through a corner, or past one by a sliver), both cells
        beside that step must be free too: the searches do not cut corners, and a line
        through the corner two blocked cells share would come nearer an obstacle than
        the inflation allows on a coarse grid (0.1 m scans).
        """
        grid = self.grid
        steps = max(2, math.ceil(math.dist(a, b) / (grid.resolution / 4)) + 1)
        t = np.arange(steps) / (steps - 1)
        scale = 1.0 / grid.resolution
        col = ((a[0] - grid.origin[0] + t * (b[0] - a[0])) * scale).astype(np.int64)
        up = ((a[1] - grid.origin[1] + t * (b[1] - a[1])) * scale).astype(np.int64)
        rows, cols = self.blocked.shape
        # astype truncates towards zero: -0.5 becomes 0, so negatives are tested first.
        if min(a[0], b[0]) < grid.origin[0] or min(a[1], b[1]) < grid.origin[1]:
            return False
        if col.max() >= cols or up.max() >= rows:
            return False
        row = rows - 1 - up
        if self.blocked[row, col].any():
            return False
        diagonal = (np.diff(row) != 0) & (np.diff(col) != 0)
        beside = (
            self.blocked[row[1:][diagonal], col[:-1][diagonal]]
            | self.blocked[row[:-1][diagonal], col[1:][diagonal]]
        )
        return not beside.any()

    def shorten(self, points: list[Point]) -> list[Point]:
        """Drop the corners that line of sight can skip (string pulling): from each kept
        point, go on while the next point is still in sight, and keep the last one that
        was. The ends are kept whatever the grid says under them: a robot close to a
        wall starts where it stands."""
        if len(points) <= 2:
            return list(points)
        kept = [points[0]]
        anchor = 0
        for j in range(2, len(points)):
            if not self.clear(points[anchor], points[j]):
                anchor = j - 1
                kept.append(points[anchor])
        kept.append(points[-1])
        return kept


def _turns(cells: list[Cell]) -> list[Cell]:
    """The cells of a grid path where it changes direction, and its two ends: the only
    corners that shortening by line of sight needs to consider."""
    kept = [cells[0]]
    for before, here, after in zip(cells, cells[1:], cells[2:], strict=False):
        if (here[0] - before[0], here[1] - before[1]) != (after[0] - here[0], after[1] - here[1]):
            kept.append(here)
    if len(cells) > 1:
        kept.append(cells[-1])
    return kept


def polyline_length(points: list[Point]) -> float:
    return sum(math.dist(a, b) for a, b in pairwise(points))
