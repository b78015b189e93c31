"""Markers that every room's stop can read, so that an arrival there can be confirmed
(issue 25).

`go` ends at its room's point (`at`) and claims an arrival only once a marker has
confirmed the pose there (missions/certainty.py). A point in the middle of a large room
can be further from every wall than a marker is read (camera/marker_reach.py): the day
room of a walled wing, 6 m from its walls, never read one with 16 cm markers, and every
arrival there was unverified. So placing markers (landmark_placement.py) makes sure each
stop reads one near enough to give its facing, or STOP_MARKERS it can read at all, whose
bearings fix the heading as well: the markers beside doorways and along walls often do;
where they do not, one goes on the wall nearest the stop. And a plan that has no
markers yet gets them as large as its farthest stop needs (`size_for_stops`), up to
LARGEST_SIZE_M.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from giraff_console.camera.marker_reach import (
    FACING_PX,
    READ_PX,
    STANDARD_SIZE_M,
    facing_reach,
    least_size,
    read_reach,
)
from giraff_console.planning.floorplan import FloorPlan, Point
from giraff_console.planning.marker_faces import Face
from giraff_console.planning.marker_sight import visible_markers
from giraff_console.planning.walls import WallSegment
from giraff_console.robot.odometry import Pose

# A stop beyond the facing reach of every marker needs this many that it can read: two
# bearings fix the heading that one marker's distance and bearing leave open.
STOP_MARKERS = 2
# The largest marker placing chooses by itself: its page is A2 (marker_pages.py). A
# stop that needs more is told, and its arrivals are reported unverified.
LARGEST_SIZE_M = 0.26
# Sizes are chosen in whole centimetres, rounded up.
SIZE_STEP_M = 0.01
# Whether a stop reads a marker is tested this far in front of it: a scanned wall is
# jagged, and a marker in a notch of it is hidden, seen aslant, by the notch's sides
# (the simulator draws the grid's walls as they are). Placed markers lie on their walls.
SIGHT_OFF_WALL_M = 0.01


@dataclass(frozen=True)
class Spot:
    """Where a marker could go for a stop: `t` along `face`, `distance` from the stop."""

    face: Face
    t: float
    distance: float

    @property
    def pose(self) -> Pose:
        return self.face.pose(self.t)


def spots(stop: Point, faces: Sequence[Face], sight: Sequence[WallSegment], size: float,
          reach: float) -> list[Spot]:  # fmt: skip
    """On each face, the free place nearest the stop's foot on it, where the stop would
    read a marker `size` across within `reach` (`sight`: the walls that hide one);
    nearest first, walls before the short faces of a grid, which may be furniture."""
    found = []
    for face in faces:
        t = face.nearest(min(max(face.position(stop), 0.0), face.length))
        if t is None:
            continue
        spot = Spot(face, t, math.dist(stop, face.point(t)))
        if visible_markers({0: spot.pose}, sight, stop, size, reach, SIGHT_OFF_WALL_M):
            found.append(spot)
    return sorted(found, key=lambda spot: (not spot.face.wall, spot.distance))


def reads(stop: Point, markers: Mapping[int, Pose], sight: Sequence[WallSegment],
          size: float) -> bool:  # fmt: skip
    """Whether the stop reads one of `markers` near enough for its facing, or
    STOP_MARKERS of them at all."""
    seen = visible_markers(markers, sight, stop, size, off_wall=SIGHT_OFF_WALL_M)
    near = facing_reach(size)
    return len(seen) >= STOP_MARKERS or any(
        math.dist(stop, (markers[i].x, markers[i].y)) <= near for i, _ in seen
    )


def size_for_stops(plan: FloorPlan, faces: Sequence[Face],
                   sight: Sequence[WallSegment]) -> float:  # fmt: skip
    """The least size, from STANDARD_SIZE_M up to LARGEST_SIZE_M, at which every room's
    stop would read markers on the walls nearest it. A stop that even LARGEST_SIZE_M
    does not let read one does not count: `place_for_stops` tells of it."""
    size = STANDARD_SIZE_M
    for room in plan.rooms.values():
        found = spots(room.at, faces, sight, STANDARD_SIZE_M, read_reach(LARGEST_SIZE_M))
        by_face = sorted({id(spot.face): spot.distance for spot in found}.values())
        if not by_face:
            continue
        needed = least_size(by_face[0], FACING_PX)
        if len(by_face) >= STOP_MARKERS:
            needed = min(needed, least_size(by_face[STOP_MARKERS - 1], READ_PX))
        needed = math.ceil(needed / SIZE_STEP_M - 1e-9) * SIZE_STEP_M
        if needed <= LARGEST_SIZE_M:
            size = max(size, round(needed, 2))
    return size


def place_for_stops(plan: FloorPlan, faces: Sequence[Face], markers: Mapping[int, Pose],
                    sight: Sequence[WallSegment],
                    size: float) -> tuple[list[tuple[Face, float]], list[str]]:  # fmt: skip
    """Markers for the rooms whose stops do not read enough of `markers` (those placed
    so far), each on the free wall nearest the stop, marked taken on its face; and a
    note for each stop that still does not."""
    poses = dict(markers)
    added: list[tuple[Face, float]] = []
    notes = []
    reach = read_reach(size)
    for room in plan.rooms.values():
        for _ in range(STOP_MARKERS):
            if reads(room.at, poses, sight, size):
                break
            found = spots(room.at, faces, sight, size, reach)
            if not found:
                break
            spot = found[0]
            spot.face.taken.append(spot.t)
            added.append((spot.face, spot.t))
            poses[-len(added)] = spot.pose  # not an id yet: placing numbers them
        if reads(room.at, poses, sight, size):
            continue
        nearest = spots(room.at, faces, sight, size, math.inf)
        where = (f"the nearest wall it sees is {nearest[0].distance:.1f} m off" if nearest
                 else "it sees no wall")  # fmt: skip
        notes.append(
            f"{room.id}: its stop at ({room.at[0]:.1f}, {room.at[1]:.1f}) reads no marker "
            f"near enough to confirm an arrival: {where}, and a {size:g} m marker is read to "
            f"{reach:.1f} m. Arrivals there will be reported unverified: larger markers "
            "(--size), or the room's point nearer a wall, mend that"
        )
    return added, notes
