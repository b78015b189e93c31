"""Which of a plan's markers the camera could read from a point: near enough for their
size, turned towards it, and no wall between.

A look for a marker turns to these (missions/localising.py), and placing markers makes
sure every room's stop has one (landmark_placement.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from giraff_console.camera.marker_reach import read_reach
from giraff_console.planning.walls import WallSegment
from giraff_console.robot.ekf import wrap
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]

# Seen more obliquely than this, a marker's square is too foreshortened to decode.
MAX_OBLIQUE = math.radians(60.0)
# The line of sight is tested for walls up to this short of the marker's own wall: a
# marker put up by hand is drawn within WALL_TOLERANCE_M of it (landmarks.py), and one
# a survey learnt, within centimetres.
OFF_WALL_M = 0.05


def visible_markers(
    markers: Mapping[int, Pose],
    walls: Sequence[WallSegment],
    here: Point,
    size: float,
    reach: float | None = None,
    off_wall: float = OFF_WALL_M,
) -> list[tuple[int, float]]:
    """The markers, `size` metres across, that the camera could read from `here` (facing
    any way): within `reach` (by default read_reach, camera/marker_reach.py), their faces
    turned towards it, and no wall of `walls` between it and either edge of their
    squares, `off_wall` in front of their centres: one cut by a corner is not decoded.
    Each as its id and its direction from `here` (radians, map frame), nearest first."""
    reach = read_reach(size) if reach is None else reach
    found = []
    for marker_id, marker in markers.items():
        dx, dy = here[0] - marker.x, here[1] - marker.y
        distance = math.hypot(dx, dy)
        if not 0 < distance <= reach:
            continue
        off_normal = abs(wrap(math.atan2(dy, dx) - marker.heading))
        if off_normal > MAX_OBLIQUE:
            continue
        if not _in_sight(marker, size, off_wall, walls, here):
            continue
        found.append((distance, marker_id, math.atan2(-dy, -dx)))
    return [(marker_id, bearing) for _, marker_id, bearing in sorted(found)]


def _in_sight(marker: Pose, size: float, off_wall: float, walls: Sequence[WallSegment],
              here: Point) -> bool:  # fmt: skip
    """Whether both edges of the marker's square, `off_wall` in front, are in sight."""
    normal = (math.cos(marker.heading), math.sin(marker.heading))
    along = (-normal[1], normal[0])
    for side in (-size / 2, size / 2):
        edge = (marker.x + off_wall * normal[0] + side * along[0],
                marker.y + off_wall * normal[1] + side * along[1])  # fmt: skip
        if crosses(walls, here, edge):
            return False
    return True


def crosses(walls: Sequence[WallSegment], p: Point, q: Point) -> bool:
    """Whether the segment p-q crosses any of `walls`."""
    if not walls:
        return False
    a = np.array([wall.a for wall in walls], dtype=float)
    b = np.array([wall.b for wall in walls], dtype=float)
    d = np.subtract(q, p)
    e = b - a
    ap = a - p
    denominator = d[0] * e[:, 1] - d[1] * e[:, 0]
    parallel = np.abs(denominator) < 1e-12
    safe = np.where(parallel, 1.0, denominator)
    t = (ap[:, 0] * e[:, 1] - ap[:, 1] * e[:, 0]) / safe
    u = (ap[:, 0] * d[1] - ap[:, 1] * d[0]) / safe
    return bool(np.any(~parallel & (t > 0) & (t < 1) & (u >= 0) & (u <= 1)))
