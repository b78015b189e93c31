"""The walls in the grid of a plan without outlines, for markers to hang on (issue 25).

A plan imported from Open-RMF or found in a scan has its rooms as points and its walls
only in its grid (floorplans/README.md, "Plans without outlines"), and the simulator
builds the building from that grid: a wall along every edge between an occupied cell and
another (sim_site.building_walls). A marker hangs flat on such a wall, its centre on an
edge, facing the free floor, its paper on one straight run of edges: the synthetic camera
draws it only where the wall lies within 0.10 m of the marker's plane (sim/camera.py),
and a scan's wall is ragged where the real one is straight, so a straight run is where
the scan saw the wall itself.

The room a wall faces is the room of the floor in front of it. The free cells, cut at
every doorway between its jambs (walls.grid_jambs, as the route planner finds them), fall
apart into pieces of floor between doorways; a piece is the floor of the rooms whose
points it holds, several where an import has several rooms in one space, joined by
passages, and a point on it is in the nearest of them (as RoutePlanner.room_at goes by
the nearest point). A piece with no room's point (a cupboard, the lawn seen through a
window) is no room's.

A face is all of one wall's edges that look one way along one grid line onto one piece of
floor, across the doorways in it and the furniture against it: a corridor wall with
doorways in it, or a bedroom's wall behind a bed, is one wall. A marker must also be seen
from where the robot drives (`seen`), not from a pocket between furniture it cannot enter.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import Door, FloorPlan, GridSpec, Point, Room
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M, walls_of
from giraff_console.planning.walls import WallSegment, grid_jambs

# The longest furniture a scan shows against a wall: a bed side-on is 2.1 m. A face's
# edges are one wall across a gap up to this long (furniture in front of it, or a
# doorway), and a face longer than this is a wall, not the side of a bed or a wardrobe.
FURNITURE_M = 2.2
# ... but open floor on the wall's line, neither wall nor furniture, only as wide as a
# doorway (a double door is 1.2 m): a bed's foot and a cell of the wall beyond it, with
# the floor between, are not one wall.
DOORWAY_M = 1.3
# A doorway is in a face when its centre is this near the face's line: the centre is
# half-way through the wall, whose faces are half its thickness away (walls up to 0.5 m).
DOOR_IN_FACE_M = 0.3
# An edge is seen when floor the robot can drive on lies straight in front of it, and
# this many degrees either side, within SEEN_FROM_M with nothing but free floor between:
# the robot then sees a marker there square on and from either side as it passes, where
# the detector reads it well, and not only from the mouth of a pocket between furniture.
SEEN_ANGLES_DEG = (0.0, -30.0, 30.0)
SEEN_FROM_M = 1.5
# Edges looked at together when finding which are seen: bounds the memory of the rays.
_CHUNK = 20000
# Each facing (degrees) and the step from a wall's cell to the cell in front of it; rows
# grow downwards (map_server's row 0 is the top of the map).
_FACINGS = ((0.0, 0, 1), (90.0, -1, 0), (180.0, 0, -1), (270.0, 1, 0))


@dataclass(frozen=True)
class GridFace:
    """One side of one wall in the grid: the edges along one grid line between occupied
    cells and the free floor they face, from `a` to `b`. Positions along it are metres
    from `a`."""

    a: Point
    b: Point
    facing: float  # degrees, the way its normal looks into the floor: 0, 90, 180 or 270
    rooms: tuple[str, ...]  # the rooms of the piece of floor it faces
    # Its straight runs of edges, and the runs of edges that are seen: (from, to), metres.
    straight: tuple[tuple[float, float], ...]
    seen: tuple[tuple[float, float], ...]

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b)


def grid_walls(plan: FloorPlan) -> GridWalls | None:
    """The walls in the plan's grid, when those are its walls (it has a grid and no
    outlines, as in the simulator); None otherwise. Read once for each grid, its image's
    state on disk and the plan's rooms and doors. OSError if the image cannot be read."""
    spec = plan.grid
    if spec is None or any(room.outline for room in plan.rooms.values()):
        return None
    state = spec.image.stat()
    return _grid_walls(spec, (state.st_mtime_ns, state.st_size), tuple(plan.rooms.values()),
                       tuple(plan.doors))  # fmt: skip


@functools.lru_cache(maxsize=2)
def _grid_walls(spec: GridSpec, version: tuple[int, int], rooms: tuple[Room, ...],
                doors: tuple[Door, ...]) -> GridWalls:  # fmt: skip
    # `version` is only part of the key: an image changed on disk is read again. Of a
    # plan with a grid, walls_of reads the grid alone.
    grid = walls_of(FloorPlan("", {}, [], spec, None, Path()))
    assert grid is not None
    return GridWalls(grid, rooms, doors)


class GridWalls:
    """A grid's walls as markers see them: every edge of its occupied cells (for the
    checks), the pieces of floor between doorways, and the faces (for placing)."""

    def __init__(self, grid: OccupancyGrid, rooms: tuple[Room, ...],
                 doors: tuple[Door, ...]) -> None:  # fmt: skip
        self.grid = grid
        self.free = grid.cells == FREE
        self.occupied = grid.cells == OCCUPIED
        self.jambs = {door.id: jambs for door in doors
                      if (jambs := grid_jambs(grid, door)) is not None}  # fmt: skip
        self.pieces = self._floor()
        self.piece_rooms: dict[int, list[Room]] = {}
        for room in rooms:
            cell = self._cell(room.at)
            if cell is not None and self.pieces[cell]:
                self.piece_rooms.setdefault(int(self.pieces[cell]), []).append(room)
        # Every edge between an occupied cell and another, as the simulator's walls.
        self.segments = []
        for facing, dr, dc in _FACINGS:
            edges = self.occupied & ~_ahead(self.occupied, dr, dc)
            self.segments += [WallSegment(*self._ends(facing, line, start, stop), facing=facing)
                              for line, start, stop, _ in _runs(_lines(edges, dc))]  # fmt: skip

    def in_wall(self, door: Door) -> bool:
        """Whether a door is a doorway in a wall: occupied cells stand either side of it.
        One that is not stands in open floor (an import's passage)."""
        return door.id in self.jambs

    def room_ahead(self, at: Point, facing: float, distance: float) -> Room | None:
        """The room a marker at `at` looks into: nothing occupied just in front of it
        (it does not face into its wall), and the floor `distance` ahead free, in a
        room's piece; None if not. Just in front may be unknown: a map made by driving
        leaves a cell unknown along much of its walls' faces (scan_outline.py ends each
        beam's free floor a cell short of its hit, across the surface): 13 % of the
        taught home's, whose markers the survey refused as facing into no room."""
        ux, uy = math.cos(math.radians(facing)), math.sin(math.radians(facing))
        near = self._cell((at[0] + ux * self.grid.resolution / 2,
                           at[1] + uy * self.grid.resolution / 2))  # fmt: skip
        if near is None or self.grid.cells[near] == OCCUPIED:
            return None
        cell = self._cell((at[0] + ux * distance, at[1] + uy * distance))
        if cell is None or not self.free[cell]:
            return None
        point = self.grid.centre_of(*cell)
        rooms = self.piece_rooms.get(int(self.pieces[cell]), [])
        return min(rooms, key=lambda room: math.dist(room.at, point), default=None)

    def face_of(self, at: Point, facing: float, within: float) -> GridFace | None:
        """The face a marker at `at` facing `facing` hangs on: facing the same way to the
        nearest right angle, its line the nearest to the centre and within `within`."""
        best, nearest = None, within
        for face in self.faces:
            if abs((face.facing - facing + 180.0) % 360.0 - 180.0) > 45.0:
                continue
            # Faces run along x (a horizontal line) or along y.
            across = 1 if face.a[1] == face.b[1] else 0
            low, high = sorted((face.a[1 - across], face.b[1 - across]))
            off = abs(at[across] - face.a[across])
            if off <= nearest and low <= at[1 - across] <= high:
                best, nearest = face, off
        return best

    @functools.cached_property
    def faces(self) -> list[GridFace]:
        """Every face onto a room's floor, with its straight runs and those seen."""
        reachable = self._reachable()
        faces = []
        for facing, dr, dc in _FACINGS:
            edge = self.occupied & _ahead(self.free, dr, dc)
            piece = np.where(edge, _ahead(self.pieces, dr, dc), 0)
            seen = np.zeros(edge.shape, dtype=bool)
            rows, cols = np.nonzero(edge)
            seen[edge] = self._seen(rows, cols, facing, reachable)
            # Where the line runs through open floor: no occupied cell either side.
            open_floor = _lines(~self.occupied & ~_ahead(self.occupied, dr, dc), dc)
            seen_runs = _runs(_lines(np.where(seen, piece, 0), dc))
            faces += self._join(facing, _runs(_lines(piece, dc)), seen_runs, open_floor)
        return faces

    def _floor(self) -> np.ndarray:
        """Each free cell's piece of floor between doorways, numbered from 1; a doorway's
        own cells go with a piece beside them."""
        cut = np.zeros(self.free.shape, dtype=np.uint8)
        for a, b in self.jambs.values():
            (ra, ca), (rb, cb) = self.grid.cell_of(*a), self.grid.cell_of(*b)
            cv2.line(cut, (ca, ra), (cb, rb), 1, 1, cv2.LINE_8)
        # Four-connected: no piece leaks diagonally through an eight-connected cut.
        _, pieces = cv2.connectedComponents((self.free & (cut == 0)).astype(np.uint8),
                                            connectivity=4, ltype=cv2.CV_32S)  # fmt: skip
        doorway = self.free & (cut > 0)
        beside = cv2.dilate(pieces.astype(np.float32), np.ones((3, 3), np.uint8))
        pieces[doorway] = beside[doorway].astype(np.int32)
        return pieces

    def _reachable(self) -> np.ndarray:
        """The cells the route planner can take the robot's centre to from the rooms'
        points: free on its inflated grid, and joined to a room's point."""
        drivable = self.grid.inflated(ROBOT_RADIUS_M + CLEARANCE_M).cells == FREE
        _, parts = cv2.connectedComponents(drivable.astype(np.uint8), connectivity=4,
                                           ltype=cv2.CV_32S)  # fmt: skip
        rooms = [room for found in self.piece_rooms.values() for room in found]
        starts = {int(parts[cell]) for room in rooms if (cell := self._cell(room.at))}
        return np.isin(parts, sorted(starts - {0}))

    def _seen(self, rows_of: np.ndarray, cols_of: np.ndarray, facing: float,
              reachable: np.ndarray) -> np.ndarray:  # fmt: skip
        """For each wall cell facing `facing`, whether its edge is seen: rays from the
        edge's middle, straight out and SEEN_ANGLES_DEG off, each reach a reachable cell
        within SEEN_FROM_M over free cells only."""
        res, (ox, oy), rows = self.grid.resolution, self.grid.origin, self.grid.shape[0]
        nx, ny = math.cos(math.radians(facing)), math.sin(math.radians(facing))
        row, col = rows_of.astype(np.float64), cols_of.astype(np.float64)
        # The edge's middle: the cell's centre, half a cell towards the floor.
        x = ox + (col + 0.5 + nx / 2) * res
        y = oy + (rows - row - 0.5 + ny / 2) * res
        steps = np.arange(res / 2, SEEN_FROM_M + res / 4, res / 2)
        seen = np.ones(len(x), dtype=bool)
        for low in range(0, len(x), _CHUNK):
            part = slice(low, low + _CHUNK)
            for angle in SEEN_ANGLES_DEG:
                ray = math.radians(facing + angle)
                ux, uy = math.cos(ray), math.sin(ray)
                c = np.floor((x[part, None] + ux * steps - ox) / res).astype(np.int64)
                r = rows - 1 - np.floor((y[part, None] + uy * steps - oy) / res).astype(np.int64)
                on = (r >= 0) & (r < rows) & (c >= 0) & (c < self.free.shape[1])
                r, c = np.where(on, r, 0), np.where(on, c, 0)
                blocked = ~(on & self.free[r, c])
                reached = on & reachable[r, c]
                first_blocked = np.where(blocked.any(axis=1), blocked.argmax(axis=1), len(steps))
                seen[part] &= reached.any(axis=1) & (reached.argmax(axis=1) < first_blocked)
        return seen

    def _join(self, facing: float, runs: list[tuple[int, int, int, int]],
              seen: list[tuple[int, int, int, int]],
              open_floor: np.ndarray) -> list[GridFace]:  # fmt: skip
        """The runs of edges facing `facing` (line, first, past-last, piece) joined into
        faces, across gaps up to FURNITURE_M with no more than DOORWAY_M of open floor
        in a row, each with its runs and the `seen` ones.

        A scanned wall is ragged: cells sticking out of it and bitten into it leave short
        runs of edges a cell in front of it and behind it, alongside. Those are the same
        wall: of two faces on neighbouring lines alongside each other, the one with less
        of its length in runs is left out."""
        join, doorway = FURNITURE_M / self.grid.resolution, DOORWAY_M / self.grid.resolution
        groups: list[_Group] = []
        for line, start, stop, piece in runs:
            if piece not in self.piece_rooms:
                continue
            last = groups[-1] if groups else None
            if (last is not None and (last.line, last.piece) == (line, piece)
                    and start - last.stop <= join
                    and _longest(open_floor[line, last.stop : start]) <= doorway):  # fmt: skip
                last.stop = stop
            else:
                groups.append(_Group(line, piece, start, stop))
        parts: dict[tuple[int, int], list[_Group]] = {}
        for group in groups:
            parts.setdefault((group.line, group.piece), []).append(group)
        for which, found in enumerate((runs, seen)):
            for line, start, stop, piece in found:
                for group in parts.get((line, piece), []):
                    if group.start <= start and stop <= group.stop:
                        group.runs[which].append((start, stop))
        res = self.grid.resolution
        faces = []
        for group in groups:
            alongside = (
                other
                for step in (-1, 1)
                for other in parts.get((group.line + step, group.piece), [])
                if min(group.stop, other.stop) > max(group.start, other.start)
            )
            if any(other.support > group.support for other in alongside):
                continue
            # Metres from the face's first cell.
            straight, seen_runs = (
                tuple(((low - group.start) * res, (high - group.start) * res) for low, high in part)
                for part in group.runs
            )
            rooms = tuple(room.id for room in self.piece_rooms[group.piece])
            ends = self._ends(facing, group.line, group.start, group.stop)
            faces.append(GridFace(*ends, facing, rooms, straight, seen_runs))
        return faces

    def _ends(self, facing: float, line: int, start: int, stop: int) -> tuple[Point, Point]:
        """The map points at either end of a run of edges facing `facing` along `line`
        (a row facing north or south, else a column), from cell `start` to before `stop`."""
        res, (ox, oy), rows = self.grid.resolution, self.grid.origin, self.grid.shape[0]
        if facing in (90.0, 270.0):
            y = oy + (rows - line - (facing == 270.0)) * res  # the top or the bottom of the row
            return (ox + start * res, y), (ox + stop * res, y)
        x = ox + (line + (facing == 0.0)) * res  # the right or the left of the column
        return (x, oy + (rows - start) * res), (x, oy + (rows - stop) * res)

    def _cell(self, point: Point) -> tuple[int, int] | None:
        try:
            return self.grid.cell_of(*point)
        except ValueError:  # off the grid
            return None


@dataclass
class _Group:
    """Runs of edges along one grid line onto one piece of floor, being joined into a
    face: cells `start` to before `stop`, with its runs and the runs of it seen."""

    line: int
    piece: int
    start: int
    stop: int
    runs: tuple[list[tuple[int, int]], list[tuple[int, int]]] = field(
        default_factory=lambda: ([], [])
    )

    @property
    def support(self) -> int:
        """How many of its cells have an edge."""
        return sum(stop - start for start, stop in self.runs[0])


def _ahead(cells: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """`cells` moved so that each holds its neighbour's value `dr` rows and `dc` columns
    on (zero or False off the grid)."""
    out = np.zeros_like(cells)
    rows, cols = cells.shape
    out[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)] = cells[
        max(0, dr) : rows + min(0, dr), max(0, dc) : cols + min(0, dc)
    ]
    return out


def _lines(cells: np.ndarray, dc: int) -> np.ndarray:
    """The grid lines edges facing that way run along, one to a row of the result:
    rows for edges facing north or south, columns for east or west."""
    return cells.T if dc else cells


def _longest(cells: np.ndarray) -> int:
    """The most True cells in a row."""
    change = np.flatnonzero(np.diff(np.concatenate(([0], cells.astype(np.int8), [0]))))
    return int((change[1::2] - change[::2]).max(initial=0))


def _runs(values: np.ndarray) -> list[tuple[int, int, int, int]]:
    """(line, first, past-last, value) of every run of one non-zero value along each
    line of `values`, in order."""
    padded = np.pad(values, ((0, 0), (1, 1)))
    inner = padded[:, 1:-1]
    starts = np.nonzero((inner != 0) & (inner != padded[:, :-2]))
    stops = np.nonzero((inner != 0) & (inner != padded[:, 2:]))
    return list(zip(starts[0].tolist(), starts[1].tolist(), (stops[1] + 1).tolist(),
                    inner[starts].tolist(), strict=True))  # fmt: skip
