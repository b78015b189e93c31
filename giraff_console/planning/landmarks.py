"""Fiducial markers on the walls of a floor plan, for the robot to find itself by (issue 14).

Dead reckoning alone drifts without bound (§2.3.1), and the casters can turn the robot
up to about 45° more than the wheels say after a turn in place (§3.2.1.5). A printed
marker at a known place on a wall fixes that: the camera sees it, cv2.aruco decodes its
id, and the plan says where that id hangs. The marker families are OpenCV's predefined
dictionaries (AprilTag 36h11 by default), so that the image printed for the wall is
exactly what the detector looks for.

The walls a marker may hang on are the outlines' edges; in a plan without outlines,
the edges of its grid's occupied cells, which are the simulator's walls too
(grid_walls.py). `floorplan check` checks the markers against them (landmark_checks.py).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector
from giraff_console.planning.floorplan import (
    DOOR_TOLERANCE_M,
    FloorPlan,
    Landmarks,
    Marker,
    Point,
    Room,
    shown,
)
from giraff_console.planning.grid_walls import DOOR_IN_FACE_M, grid_walls
from giraff_console.planning.walls import WallSegment, wall_segments
from giraff_console.robot.marker_map import (
    MarkerBelief,
    MarkerState,
    hand_covariance,
    on_wall_covariance,
)
from giraff_console.robot.odometry import Pose

# OpenCV's predefined dictionaries by the names a floor plan uses: DICT_APRILTAG_36h11
# is `apriltag_36h11`. OpenCV spells some twice (36h11 and 36H11): one name each here.
FAMILIES: dict[str, int] = {
    name.removeprefix("DICT_").lower(): getattr(cv2.aruco, name)
    for name in dir(cv2.aruco)
    if name.startswith("DICT_")
}

# A marker's centre may be this far from a wall (the outline edge): a hand-measured
# position is good to a few centimetres, and a wall is about 10 cm thick.
WALL_TOLERANCE_M = 0.05
# A marker lies flat on its wall, so its normal is the wall's. The filter takes the
# marker's facing from the plan: a facing 2° off turns into a 2° heading error, against
# the 3° the robot must keep to (issue 14), so no more than that is let through.
FACING_TOLERANCE_DEG = 2.0
# How far in front of a marker a point must lie inside a room for it to face into one.
IN_FRONT_M = 0.25
# White paper round the black square, in cells: the detector needs the square's edge to
# stand against something light, and a wall may be dark. Pages are cut along this.
PAPER_MARGIN_CELLS = 2


def aruco_dictionary(family: str) -> cv2.aruco.Dictionary:
    """The cv2.aruco dictionary of a family named as in a floor plan; ValueError if
    OpenCV has none by that name."""
    if family not in FAMILIES:
        raise ValueError(
            f"unknown marker family {shown(family)}: a cv2.aruco predefined dictionary, "
            f"one of {', '.join(sorted(FAMILIES))}"
        )
    return cv2.aruco.getPredefinedDictionary(FAMILIES[family])


def id_count(family: str) -> int:
    """How many markers the family has: ids run from 0 to one less."""
    return int(aruco_dictionary(family).bytesList.shape[0])


def cells(family: str) -> int:
    """Cells along a side of the black square, its one-cell black border included."""
    return int(aruco_dictionary(family).markerSize) + 2


def marker_image(family: str, marker_id: int, side_px: int) -> np.ndarray:
    """The black square of marker `marker_id`, `side_px` pixels a side, 0 black and 255
    white, from OpenCV's own generator; without the white paper round it."""
    return cv2.aruco.generateImageMarker(aruco_dictionary(family), marker_id, side_px, borderBits=1)


def paper_side(family: str, size: float) -> float:
    """The side of the paper a marker is printed on and cut to, metres."""
    count = cells(family)
    return size * (count + 2 * PAPER_MARGIN_CELLS) / count


# Geometry shared with placement and the printed pages.


def unit(degrees: float) -> Point:
    return math.cos(math.radians(degrees)), math.sin(math.radians(degrees))


def angle_between(a: float, b: float) -> float:
    """The difference between two directions in degrees, 0 to 180."""
    return abs((a - b + 180.0) % 360.0 - 180.0)


def inside(point: Point, outline: Sequence[Point]) -> bool:
    """Whether the point lies inside the polygon (on an edge counts as outside)."""
    try:
        contour = _contour(outline)
    except TypeError:  # points as lists, not read from a file: made afresh
        contour = np.array(outline, dtype=np.float32).reshape(-1, 1, 2)
    return cv2.pointPolygonTest(contour, (float(point[0]), float(point[1])), False) > 0


@functools.lru_cache(maxsize=1024)
def _contour(outline: Sequence[Point]) -> np.ndarray:
    """An outline as OpenCV takes it, made once: a plan's markers are checked against
    every room's outline as the plan loads (landmark_checks.py: for the example's 176
    markers, 2,662 arrays each time it was loaded). Read-only, as it is shared. Outlines
    are tuples (floorplan.Room), hashable."""
    contour = np.array(outline, dtype=np.float32).reshape(-1, 1, 2)
    contour.flags.writeable = False
    return contour


def room_in_front(plan: FloorPlan, at: Point, facing: float) -> Room | None:
    """The room a marker at `at` facing `facing` looks into, if any: the outline holding
    the point IN_FRONT_M ahead of it, or on a grid, the room of the free floor there."""
    walls = grid_walls(plan)
    if walls is not None:
        return walls.room_ahead(at, facing, IN_FRONT_M)
    dx, dy = unit(facing)
    ahead = (at[0] + dx * IN_FRONT_M, at[1] + dy * IN_FRONT_M)
    for room in plan.rooms.values():
        if room.outline and inside(ahead, room.outline):
            return room
    return None


class MarkerWalls:
    """The walls a marker may hang on, with their ends as arrays to measure against."""

    def __init__(self, segments: Sequence[WallSegment]) -> None:
        self.segments = tuple(segments)
        self.a = np.array([wall.a for wall in segments], dtype=np.float64).reshape(-1, 2)
        self.b = np.array([wall.b for wall in segments], dtype=np.float64).reshape(-1, 2)
        self.d = self.b - self.a
        span = np.einsum("ij,ij->i", self.d, self.d)
        self.span = np.where(span == 0, 1.0, span)
        # The same by coordinate, for `distances`: measured three times for each marker as
        # a plan loads, and half the time of the 2-D form (issue 26, item 6).
        self._ax, self._ay = self.a[:, 0].copy(), self.a[:, 1].copy()
        self._dx, self._dy = self.d[:, 0].copy(), self.d[:, 1].copy()

    def __bool__(self) -> bool:
        return bool(self.segments)

    def distances(self, point: Point) -> np.ndarray:
        """The distance from `point` to each wall."""
        rx, ry = float(point[0]) - self._ax, float(point[1]) - self._ay
        t = np.clip((rx * self._dx + ry * self._dy) / self.span, 0.0, 1.0)
        return np.hypot(rx - t * self._dx, ry - t * self._dy)


def marker_walls(plan: FloorPlan) -> MarkerWalls:
    """The walls a marker may hang on: every wall and door frame; not a door, which
    swings, and not a doorway. Without outlines, every edge of the grid's occupied cells.
    OSError if the grid cannot be read."""
    walls = grid_walls(plan)
    if walls is not None:
        return MarkerWalls(walls.segments)
    return MarkerWalls([segment for segment in wall_segments(plan) if segment.kind != "door"])


def wall_direction(wall: WallSegment) -> float:
    """The wall's direction, degrees counter-clockwise from +x."""
    return math.degrees(math.atan2(wall.b[1] - wall.a[1], wall.b[0] - wall.a[0]))


def facing_error(wall: WallSegment, facing: float) -> float:
    """How far `facing` is from square to the wall, on whichever side, in degrees."""
    normal = wall_direction(wall) + 90.0
    return min(angle_between(facing, normal), angle_between(facing, normal + 180.0))


@dataclass(frozen=True)
class WallFit:
    """How a marker sits on the plan's walls."""

    wall: WallSegment | None  # the wall it is on: near it, and the squarest of those
    distance: float  # from the nearest wall, metres


def fit_on_walls(at: Point, facing: float, walls: MarkerWalls) -> WallFit:
    distances = walls.distances(at)
    near = [walls.segments[i] for i in np.flatnonzero(distances <= WALL_TOLERANCE_M)]
    best = min(near, key=lambda wall: facing_error(wall, facing), default=None)
    return WallFit(best, float(distances.min()))


# Where a marker goes, in words for the people who put it up.

_COMPASS = (
    "east",
    "north-east",
    "north",
    "north-west",
    "west",
    "south-west",
    "south",
    "south-east",
)
# A door this close to a marker (from the doorway's edge) is what its place is told from.
NEAR_DOOR_M = 2.0


@dataclass(frozen=True)
class MarkerPlace:
    room: Room  # the room it faces into, where it is put up from
    wall: str  # "north wall": the compass of the map, north up
    beside: str  # "centre 0.31 m right of the doorway to Main corridor"

    def __str__(self) -> str:
        return f"{self.room.id}, {self.wall}, {self.beside}"


def compass(degrees: float) -> str:
    return _COMPASS[round((degrees % 360.0) / 45.0) % 8]


def where_it_goes(plan: FloorPlan, marker: Marker) -> MarkerPlace | None:
    """The room a marker is in, which of its walls, and where along it, told from the
    nearest doorway on that wall or else its nearer corner, as seen facing the wall.
    None for a marker that faces into no room, or is on no wall of it."""
    found = _wall_of(plan, marker)
    if found is None:
        return None
    room, rooms, (a, b), depth = found
    nx, ny = unit(marker.facing)
    right = (-ny, nx)  # along the wall, to the right of someone facing it
    wall = f"{compass(marker.facing + 180.0)} wall"

    def offset(point: Point) -> float:
        """How far right of `point` the marker's centre is, along the wall."""
        return (marker.at[0] - point[0]) * right[0] + (marker.at[1] - point[1]) * right[1]

    best = None
    for door in plan.doors:
        if _to_segment(door.at, a, b) > depth or len(rooms.intersection(door.between)) != 1:
            continue
        along = offset(door.at)
        gap = abs(along) - door.width / 2
        if gap <= NEAR_DOOR_M and (best is None or gap < best[0]):
            best = (gap, along, door)
    if best is not None:
        gap, along, door = best
        other = plan.rooms[next(r for r in door.between if r not in rooms)]
        side = "right" if along > 0 else "left"
        return MarkerPlace(room, wall, f"centre {gap:.2f} m {side} of the doorway to {other.label}")
    corner = min((a, b), key=lambda end: abs(offset(end)))
    side = "left" if offset(corner) > 0 else "right"
    return MarkerPlace(
        room, wall, f"centre {abs(offset(corner)):.2f} m from the {side}-hand corner"
    )


def _wall_of(
    plan: FloorPlan, marker: Marker
) -> tuple[Room, frozenset[str], tuple[Point, Point], float] | None:
    """The room a marker faces into, the rooms whose floor its wall faces, the wall's
    ends, and how far from the wall a doorway's centre may lie and be in it: the edge
    of the room's outline nearest the marker, or the face of the grid it hangs on."""
    room = room_in_front(plan, marker.at, marker.facing)
    if room is None:
        return None
    walls = grid_walls(plan)
    if walls is not None:
        face = walls.face_of(marker.at, marker.facing, WALL_TOLERANCE_M)
        if face is None:
            return None
        return room, frozenset(face.rooms), (face.a, face.b), DOOR_IN_FACE_M
    if not room.outline:
        return None
    edges = list(zip(room.outline, [*room.outline[1:], room.outline[0]], strict=True))
    edge = min(edges, key=lambda edge: _to_segment(marker.at, *edge))
    return room, frozenset([room.id]), edge, DOOR_TOLERANCE_M


def _to_segment(p: Point, a: Point, b: Point) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    span = dx * dx + dy * dy
    t = 0.0 if span == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / span))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def marker_poses(plan: FloorPlan, known_only: bool = False) -> dict[int, Pose]:
    """Each of the plan's markers as the pose filter takes it: its centre on the wall,
    and the way its face looks in radians (robot/localisation.py); none without
    landmarks. `known_only`: not those a survey left too loosely known to use."""
    if plan.landmarks is None:
        return {}
    if known_only:
        return {marker_id: belief.pose for marker_id, belief in marker_beliefs(plan).items()
                if belief.state is MarkerState.KNOWN}  # fmt: skip
    return {marker.id: Pose(marker.at[0], marker.at[1], math.radians(marker.facing))
            for marker in plan.landmarks.markers}  # fmt: skip


def marker_beliefs(plan: FloorPlan) -> dict[int, MarkerBelief]:
    """Each of the plan's markers as the localisation finds the robot by it: its pose
    (marker_poses) and how well that is known (robot/marker_map.py): as a survey wrote
    it, on its wall (the plan's checks saw it is on one when it was loaded; OSError if
    the grid's walls cannot be read now), else a tape measure's. A marker the survey
    left loosely known is learnt, not used, until sightings make it known well enough."""
    beliefs = {}
    markers = markers_by_id(plan)
    surveyed = any(marker.sigma is not None for marker in markers.values())
    walls = marker_walls(plan) if surveyed else MarkerWalls([])
    for marker_id, pose in marker_poses(plan).items():
        marker = markers[marker_id]
        sigma = marker.sigma
        if sigma is None:
            covariance = hand_covariance()
        else:
            off_wall = fit_on_walls(marker.at, marker.facing, walls).distance if walls else 0.0
            covariance = on_wall_covariance(sigma[0], math.radians(sigma[1]), pose.heading,
                                            off_wall)  # fmt: skip
        belief = MarkerBelief(pose, covariance)
        if not belief.well_known:
            belief = MarkerBelief(pose, covariance, MarkerState.LEARNING)
        beliefs[marker_id] = belief
    return beliefs


def markers_by_id(plan: FloorPlan) -> dict[int, Marker]:
    return {marker.id: marker for marker in plan.landmarks.markers} if plan.landmarks else {}


def marker_detector(
    landmarks: Landmarks, intrinsics: Callable[[int, int], CameraIntrinsics | None]
) -> MarkerDetector:
    """The detector for a plan's markers: its family and size, looking for its ids only
    (a plan with none yet: every id of the family), which saves decoding every other
    marker of the family in each square-looking thing in the frame."""
    ids = [marker.id for marker in landmarks.markers]
    return MarkerDetector(landmarks.family, landmarks.size, intrinsics, ids=ids or None)
