"""A floor plan's walls as line segments: the room outlines with their doorways cut out.

The synthetic camera and the simulated range finder see the building through these,
so that what the robot sees matches the plan it is driven on. A closed door is a
segment of its own across its doorway.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

from giraff_console.planning.floorplan import DOOR_TOLERANCE_M, Door, FloorPlan, Point

# How far along the wall a door frame reaches on each side of the doorway.
FRAME_M = 0.08


@dataclass(frozen=True)
class WallSegment:
    a: Point
    b: Point
    kind: str = "wall"  # "wall", "frame" (beside a doorway) or "door" (a closed one)

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
            segments += _cut(a, b, [door for door in plan.doors if _on_edge(door, a, b)], shut)
    return segments


def doorway(plan: FloorPlan, door: Door) -> tuple[Point, Point]:
    """The two ends of a door's doorway, its jambs: along the wall it is in, the outline
    edge of one of its rooms, or, without one, square to the line between their points."""
    for room_id in door.between:
        outline = plan.rooms[room_id].outline
        if not outline:
            continue
        for a, b in pairwise([*outline, outline[0]]):
            if _on_edge(door, a, b):
                length = math.dist(a, b)
                ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
                return _jambs(door, ux, uy)
    (ax, ay), (bx, by) = (plan.rooms[room_id].at for room_id in door.between)
    length = math.hypot(bx - ax, by - ay) or 1.0
    return _jambs(door, -(by - ay) / length, (bx - ax) / length)


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
