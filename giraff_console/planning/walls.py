"""A floor plan's walls as line segments: the room outlines with their doorways cut out.

The synthetic camera and the simulated range finder see the building through these,
so that what the robot sees matches the plan it is driven on. A closed door is a
segment of its own across its doorway.

A plan without outlines (an RMF import, or room points and doors over a scan) has its
walls only in its grid: there a door's wall is found from the occupied cells on either
side of it (`grid_jambs`), and a door with none is in no wall at all (a door an import
put half-way along a lane in open floor).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from giraff_console.planning.floorplan import DOOR_TOLERANCE_M, Door, FloorPlan, Point
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid

# How far along the wall a door frame reaches on each side of the doorway.
FRAME_M = 0.08
# How far beyond half its width a door's jambs may stand on a grid: a door's width is
# written by hand (0.9 m when it is not), and real doorways are 0.8 to 1.2 m or more.
# Far enough too that a door in a narrow corridor, with no wall of its own, finds the
# corridor's walls: it is then crossed along the corridor, which the robot does anyway.
JAMB_SLACK_M = 0.5


@dataclass(frozen=True)
class WallSegment:
    a: Point
    b: Point
    kind: str = "wall"  # "wall", "frame" (beside a doorway) or "door" (a closed one)
    # Degrees: the way the floor in front of it lies, where that is known (a face of a
    # grid's wall: grid_walls.py); None for an outline's edge, seen from either side.
    facing: float | None = None

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b)


def wall_segments(plan: FloorPlan, closed: frozenset[str] = frozenset()) -> list[WallSegment]:
    """Every outline edge, cut at the open doors on it; closed doors (those in `closed`
    and those the plan has shut) span their doorways."""
    segments: list[WallSegment] = []
    shut = {door.id for door in plan.doors if not door.open} | set(closed)
    for room in plan.rooms.values():
        if not room.outline:
            continue
        corners = [*room.outline, room.outline[0]]
        for a, b in pairwise(corners):
            segments += _cut(a, b, _doors_on(plan.doors, a, b), shut)
    return segments


def _doors_on(doors: Sequence[Door], a: Point, b: Point) -> list[Door]:
    """The doors on the edge a-b (_on_edge), the edge measured once for all of them: the
    example's 384 edges times its 34 doors, each time its walls are drawn (three times
    as the console starts, issue 26, item 6)."""
    length = math.dist(a, b)
    if length == 0:
        return []
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    on = []
    for door in doors:
        px, py = door.at[0] - a[0], door.at[1] - a[1]
        t = px * ux + py * uy
        if 0 <= t <= length and abs(px * uy - py * ux) <= DOOR_TOLERANCE_M:
            on.append(door)
    return on


def doorway(plan: FloorPlan, door: Door, grid: OccupancyGrid | None = None) -> tuple[Point, Point]:
    """The two ends of a door's doorway, its jambs: along the wall it is in, the outline
    edge of one of its rooms; else, on `grid`, the occupied cells either side of it (a
    plan without outlines); else square to the line between their points."""
    edge = wall_edge(plan, door)
    if edge is not None:
        _, a, b = edge
        length = math.dist(a, b)
        return _jambs(door, (b[0] - a[0]) / length, (b[1] - a[1]) / length)
    jambs = grid_jambs(grid, door) if grid is not None else None
    if jambs is not None:
        return jambs
    (ax, ay), (bx, by) = (plan.rooms[room_id].at for room_id in door.between)
    length = math.hypot(bx - ax, by - ay) or 1.0
    return _jambs(door, -(by - ay) / length, (bx - ax) / length)


def wall_edge(plan: FloorPlan, door: Door) -> tuple[str, Point, Point] | None:
    """The outline edge a door is in, as (room id, one corner, the next), from the first
    of its rooms whose outline has one within DOOR_TOLERANCE_M of the door's centre;
    None when neither has (no outlines, or a door drawn away from them)."""
    for room_id in door.between:
        outline = plan.rooms[room_id].outline
        if not outline:
            continue
        for a, b in pairwise([*outline, outline[0]]):
            if _on_edge(door, a, b) and math.dist(a, b) > 0:
                return room_id, a, b
    return None


def grid_jambs(grid: OccupancyGrid, door: Door) -> tuple[Point, Point] | None:
    """The centres of the occupied cells either side of a door on `grid`: the one
    nearest its centre, and the nearest on the far side of the centre from that one,
    each within half its width and JAMB_SLACK_M. The wall the door is in runs from one
    to the other. None when there are not occupied cells on both sides: there is no
    wall at the door to cross (or its centre is itself on a wall)."""
    reach = door.width / 2 + JAMB_SLACK_M
    rows, cols = grid.cells.shape
    x, y = door.at
    # Cells as floats first: a door may lie off the grid, where cell_of raises.
    col = math.floor((x - grid.origin[0]) / grid.resolution)
    row = rows - 1 - math.floor((y - grid.origin[1]) / grid.resolution)
    span = math.ceil(reach / grid.resolution) + 1
    top, left = max(0, row - span), max(0, col - span)
    bottom, right = min(rows, row + span + 1), min(cols, col + span + 1)
    if top >= bottom or left >= right:
        return None
    found = np.nonzero(grid.cells[top:bottom, left:right] == OCCUPIED)
    xs = grid.origin[0] + (found[1] + left + 0.5) * grid.resolution - x
    ys = grid.origin[1] + (rows - (found[0] + top) - 0.5) * grid.resolution - y
    near = np.hypot(xs, ys) <= reach
    xs, ys = xs[near], ys[near]
    if not len(xs):
        return None
    first = int(np.argmin(np.hypot(xs, ys)))
    fx, fy = float(xs[first]), float(ys[first])
    beyond = xs * fx + ys * fy < 0  # on the far side of the line through the centre
    if not beyond.any():
        return None
    far = np.flatnonzero(beyond)[int(np.argmin(np.hypot(xs[beyond], ys[beyond])))]
    return (x + fx, y + fy), (x + float(xs[far]), y + float(ys[far]))


def _jambs(door: Door, ux: float, uy: float) -> tuple[Point, Point]:
    half = door.width / 2
    x, y = door.at
    return (x - ux * half, y - uy * half), (x + ux * half, y + uy * half)


def _on_edge(door: Door, a: Point, b: Point) -> bool:
    return _along(door.at, a, b) is not None


def _along(point: Point, a: Point, b: Point) -> float | None:
    """How far along a-b the point lies, if it lies on the edge (within the tolerance)."""
    length = math.dist(a, b)
    if length == 0:
        return None
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    t = (point[0] - a[0]) * ux + (point[1] - a[1]) * uy
    off = abs((point[0] - a[0]) * uy - (point[1] - a[1]) * ux)
    return t if 0 <= t <= length and off <= DOOR_TOLERANCE_M else None


def _cut(a: Point, b: Point, doors: list[Door], shut: set[str]) -> list[WallSegment]:
    length = math.dist(a, b)
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length

    def at(t: float) -> Point:
        return (a[0] + ux * t, a[1] + uy * t)

    pieces: list[WallSegment] = []
    start = 0.0
    for door in sorted(doors, key=lambda door: _along(door.at, a, b) or 0.0):
        centre = _along(door.at, a, b)
        assert centre is not None
        low, high = max(0.0, centre - door.width / 2), min(length, centre + door.width / 2)
        before = max(start, low - FRAME_M)
        if before > start:
            pieces.append(WallSegment(at(start), at(before)))
        if low > before:
            pieces.append(WallSegment(at(before), at(low), "frame"))
        if door.id in shut:
            pieces.append(WallSegment(at(low), at(high), "door"))
        after = min(length, high + FRAME_M)
        if after > high:
            pieces.append(WallSegment(at(high), at(after), "frame"))
        start = max(start, after)
    if start < length:
        pieces.append(WallSegment(at(start), b))
    return pieces
