"""What the map shows: the still parts of a floor plan (walls, doors, rooms, markers)
and what moves (the robot, how well it knows where it is, its path, the obstacles and
the markers it saw), as one immutable scene for map_canvas to draw."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from giraff_console.planning.floorplan import FloorPlan
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.service.vocabulary import Estimate, Pose

Point = tuple[float, float]


@dataclass(frozen=True)
class DoorMark:
    """A door as the map draws it: a line across its doorway, green open or red shut."""

    id: str
    centre: Point
    width: float  # metres
    open: bool
    along: Point = (1.0, 0.0)  # unit vector along the wall, across the doorway


@dataclass(frozen=True)
class MarkerMark:
    """A landmark as the map draws it: a spot on its wall, on the side it faces."""

    id: int
    at: Point  # its centre on the wall
    facing: float  # radians from +x: the way its face looks, into the room


@dataclass(frozen=True)
class MapScene:
    """What the map shows. Make a new one (dataclasses.replace) whenever anything moves:
    an equal scene is not drawn again."""

    walls: OccupancyGrid  # the plan's own grid, not inflated: the operator sees real walls
    doors: tuple[DoorMark, ...] = ()
    labels: tuple[tuple[str, Point], ...] = ()
    robot: tuple[float, float, float] | None = None  # x, y, heading in radians
    path: tuple[Point, ...] = ()
    obstacles: tuple[Point, ...] = ()
    robot_radius: float = 0.3
    markers: tuple[MarkerMark, ...] = ()
    seen: tuple[int, ...] = ()  # ids of markers that corrected the pose lately
    rejected: tuple[int, ...] = ()  # ids of markers the gate turned down lately
    # The 1-sigma position ellipse about the robot (Estimate.ellipse): semi-major and
    # semi-minor axes in metres, the major axis's direction in radians from +x.
    ellipse: tuple[float, float, float] | None = None


def wall_direction(grid: OccupancyGrid, centre: Point, width: float) -> Point:
    """The unit vector along the wall a door of `width` at `centre` is cut into.

    Rays through the centre are probed every 15 degrees beyond the doorway's half-width;
    the wall is the one that meets the most occupied cells on both sides. A straight
    probe, unlike fitting the nearby wall cells, is not swayed by a corner next to the
    door. Horizontal if no wall is near.
    """
    angles = np.radians(np.arange(0, 180, 15))
    step = grid.resolution / 2
    reach = np.arange(width / 4, width / 2 + 0.5, step)
    offsets = np.concatenate((reach, -reach))
    xs = centre[0] + np.cos(angles)[:, None] * offsets
    ys = centre[1] + np.sin(angles)[:, None] * offsets
    rows, cols = grid.shape
    col = np.floor((xs - grid.origin[0]) / grid.resolution).astype(int)
    row = rows - 1 - np.floor((ys - grid.origin[1]) / grid.resolution).astype(int)
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    walls = np.zeros(xs.shape, bool)
    walls[inside] = grid.cells[row[inside], col[inside]] == OCCUPIED
    best = int(np.argmax(walls.sum(axis=1)))
    if not walls[best].any():
        return 1.0, 0.0
    # Rounded, so that a vertical wall is (0, 1) and not (6e-17, 1).
    return round(float(np.cos(angles[best])), 9), round(float(np.sin(angles[best])), 9)


def plan_scene(plan: FloorPlan, grid: OccupancyGrid) -> MapScene:
    """The still parts of a plan's map: its walls, its doors, its rooms' ids, which are
    what the operator types ("go room-101"), and its markers."""
    doors = tuple(
        DoorMark(door.id, door.at, door.width, door.open, wall_direction(grid, door.at, door.width))
        for door in plan.doors
    )
    labels = tuple((room_id, room.at) for room_id, room in plan.rooms.items())
    landmarks = plan.landmarks.markers if plan.landmarks is not None else ()
    markers = tuple(MarkerMark(m.id, m.at, math.radians(m.facing)) for m in landmarks)
    return MapScene(grid, doors, labels, markers=markers)


def located(scene: MapScene, pose: Pose, estimate: Estimate | None) -> MapScene:
    """`scene` with the robot at `pose` and, from the estimate if there is one, how well
    that is known (its 1-sigma ellipse) and which markers were seen and rejected lately."""
    robot = (pose.x, pose.y, pose.heading)
    if estimate is None:
        return replace(scene, robot=robot, ellipse=None, seen=(), rejected=())
    # None until the filter has an ellipse: it has none before it is placed.
    ellipse = estimate.ellipse if all(map(math.isfinite, estimate.ellipse)) else None
    return replace(scene, robot=robot, ellipse=ellipse, seen=estimate.seen,
                   rejected=estimate.rejected)  # fmt: skip
