"""Where on a floor plan's walls markers can go: each side of each wall as a `Face`.

A plan with outlines has its walls in them: each edge of a room's outline, seen from
inside the room. A plan without (an import, or rooms found in a scan) has them in its
grid, as the simulator does (grid_walls.py): each face of a wall onto a room's floor,
where a marker may go only on a straight run of it that the robot sees. Either way a
face says what along it is taken (doorways, corners, other markers' paper), so that
placing (landmark_placement.py) is the same for both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import pairwise

from giraff_console.planning.floorplan import DOOR_TOLERANCE_M, Door, FloorPlan, Marker, Point
from giraff_console.planning.grid_walls import DOOR_IN_FACE_M, FURNITURE_M, grid_walls
from giraff_console.planning.landmarks import (
    FACING_TOLERANCE_DEG,
    WALL_TOLERANCE_M,
    angle_between,
)
from giraff_console.planning.walls import FRAME_M
from giraff_console.robot.odometry import Pose

# Clear wall kept between a marker's paper and a door frame, a corner, another marker.
DOOR_GAP_M = 0.15
CORNER_GAP_M = 0.10
MARKER_GAP_M = 0.30


@dataclass
class Face:
    """One side of one wall, seen from the floor in front of it. Positions along it are
    metres from `a`."""

    rooms: frozenset[str]  # the rooms whose floor it faces
    a: Point
    b: Point
    facing: float  # the normal into the room, degrees
    paper: float  # the side of a marker's paper
    blocked: list[tuple[float, float]] = field(default_factory=list)  # doorways, corners
    # Where the paper may be but not the centre: on a grid, edges not seen from the floor.
    hidden: list[tuple[float, float]] = field(default_factory=list)
    taken: list[float] = field(default_factory=list)  # markers' centres
    # How far from the face a doorway's centre may lie and be in it: on the outline
    # edge, or half-way through a wall of the grid.
    door_depth: float = DOOR_TOLERANCE_M
    # Whether it is surely a wall: an outline's edge is; a short face of the grid may be
    # the side of a bed, which gets no markers along it and none for a doorway nearby.
    wall: bool = True

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b)

    @property
    def along(self) -> Point:
        return (self.b[0] - self.a[0]) / self.length, (self.b[1] - self.a[1]) / self.length

    def point(self, t: float) -> Point:
        return self.a[0] + self.along[0] * t, self.a[1] + self.along[1] * t

    def pose(self, t: float) -> Pose:
        """A marker's pose at `t`, as the pose filter takes it (its normal in radians)."""
        x, y = self.point(t)
        return Pose(x, y, math.radians(self.facing))

    def position(self, point: Point) -> float:
        return (point[0] - self.a[0]) * self.along[0] + (point[1] - self.a[1]) * self.along[1]

    def off_line(self, point: Point) -> float:
        """How far `point` lies from the face's line, however far along."""
        ux, uy = self.along
        return abs((point[0] - self.a[0]) * uy - (point[1] - self.a[1]) * ux)

    def distance(self, point: Point) -> float:
        t = self.position(point)
        return self.off_line(point) if 0 <= t <= self.length else math.inf

    def holds(self, marker: Marker) -> bool:
        return (self.distance(marker.at) <= WALL_TOLERANCE_M
                and angle_between(marker.facing, self.facing) <= FACING_TOLERANCE_DEG)  # fmt: skip

    def holds_door(self, door: Door) -> bool:
        """Whether the doorway is in this wall: its centre within `door_depth` of the
        line, and its opening on the face (a face of the grid ends where a doorway at
        the end of its wall begins)."""
        half = door.width / 2
        t = self.position(door.at)
        return self.off_line(door.at) <= self.door_depth and -half <= t <= self.length + half

    def free(self) -> list[tuple[float, float]]:
        """Where a marker's centre may go: its paper clear of doorways, corners and
        other markers, by the gaps above."""
        half = self.paper / 2
        walls = [(-math.inf, CORNER_GAP_M), (self.length - CORNER_GAP_M, math.inf), *self.blocked]
        walls += [(t - half - MARKER_GAP_M, t + half + MARKER_GAP_M) for t in self.taken]
        spans: list[tuple[float, float]] = []
        start = -math.inf
        for low, high in sorted([(low - half, high + half) for low, high in walls] + self.hidden):
            if low > start:
                spans.append((start, low))
            start = max(start, high)
        return [(low, high) for low, high in spans if math.isfinite(low) and math.isfinite(high)]

    def nearest(self, t: float, side: int = 0, within: float = math.inf) -> float | None:
        """The free position nearest `t`, only beyond it (`side` 1) or before it (-1)."""
        best = None
        for low, high in self.free():
            if side > 0:
                low = max(low, t)
            elif side < 0:
                high = min(high, t)
            if low <= high:
                here = min(max(t, low), high)
                if abs(here - t) <= within and (best is None or abs(here - t) < abs(best - t)):
                    best = here
        return best


def marker_faces(plan: FloorPlan, paper: float) -> tuple[list[Face], list[Door]]:
    """The faces of the plan's walls for markers of paper `paper` a side, and the doors
    that are doorways in walls, to put markers beside. ValueError for a plan with no
    walls to hang them on. OSError if its grid image cannot be read."""
    walls = grid_walls(plan)
    if walls is None:
        faces = _outline_faces(plan, paper)
        doorways = plan.doors
    else:
        faces = []
        for wall in walls.faces:
            face = Face(frozenset(wall.rooms), wall.a, wall.b, wall.facing, paper,
                        door_depth=DOOR_IN_FACE_M, wall=wall.length >= FURNITURE_M)  # fmt: skip
            # The paper on a straight run of the wall, its centre where the robot sees it.
            face.blocked += _between(wall.straight, face.length)
            face.hidden += _between(wall.seen, face.length)
            faces.append(face)
        # A door in open floor (an import's passage) is in no wall, so has no side.
        doorways = [door for door in plan.doors if walls.in_wall(door)]
    if not faces:
        why = ("no room has an outline, and there is no grid" if plan.grid is None
               else "no wall in its grid faces a room's floor")  # fmt: skip
        raise ValueError(f"{plan.path}: {why}, so there are no walls to put markers on")
    for face in faces:
        for door in plan.doors:
            if face.holds_door(door):
                t = face.position(door.at)
                reach = door.width / 2 + FRAME_M + DOOR_GAP_M
                face.blocked.append((t - reach, t + reach))
    return faces, doorways


def _between(runs: tuple[tuple[float, float], ...], length: float) -> list[tuple[float, float]]:
    """The stretches from 0 to `length` outside the runs."""
    ends = [0.0, *(t for run in runs for t in run), length]
    return [(low, high) for low, high in zip(ends[::2], ends[1::2], strict=True) if high > low]


def _outline_faces(plan: FloorPlan, paper: float) -> list[Face]:
    faces = []
    for room in plan.rooms.values():
        outline = room.outline
        if not outline:
            continue
        # The normal into the room is to the left of an edge going round the outline
        # counter-clockwise, to the right going clockwise: outlines may run either way.
        turn = 0.0 if _counter_clockwise(outline) else 180.0
        for a, b in pairwise([*outline, outline[0]]):
            if math.dist(a, b) == 0:
                continue
            left = math.degrees(math.atan2(b[0] - a[0], -(b[1] - a[1])))
            faces.append(Face(frozenset([room.id]), a, b, (left + turn) % 360.0, paper))
    return faces


def _counter_clockwise(outline: tuple[Point, ...]) -> bool:
    area = sum(ax * by - bx * ay for (ax, ay), (bx, by)
               in zip(outline, [*outline[1:], outline[0]], strict=True))  # fmt: skip
    return area > 0
