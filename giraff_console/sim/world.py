"""The simulated world the synthetic camera sees: walls, door frames, posters and markers.

A built-in demo world stands in when there is no floor plan: two rooms joined by a
doorway, with panelled walls, dark door frames and chequered posters, so that a corner
detector has something to find wherever the robot looks.

Fiducial markers (issue 14) hang on the walls as printed: a black square of `size`
metres holding the marker's bits, on white paper. The simulator knows only the pattern
of cells, not what family it belongs to; `marker_pattern` takes it from a cv2.aruco
dictionary, so the camera draws exactly what a detector looks for.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

WALL, DOOR_FRAME = 0, 1
# Poster size, and the height of its lower edge, in metres.
POSTER_WIDTH = 0.6
POSTER_HEIGHT = 0.8
POSTER_BOTTOM = 1.1


@dataclass(frozen=True)
class Wall:
    """A wall segment; `poster_at` is where along it a poster starts (metres), if any."""

    x1: float
    y1: float
    x2: float
    y2: float
    kind: int = WALL
    poster_at: float = math.nan


# White paper around the black square, in cells: the detector needs the square's outer
# edge to stand against something light. The printed pages are cut with this margin
# (planning/landmarks.py, PAPER_MARGIN_CELLS; the simulator does not import planning).
QUIET_ZONE_CELLS = 2


@dataclass(frozen=True, eq=False)
class WorldMarker:
    """A fiducial marker on a wall.

    (`x`, `y`) is its centre in the map frame, `height` the centre above the floor,
    `facing` the way its face looks (its normal, radians counter-clockwise from +x), and
    `size` the side of the black square in metres. `pattern` is the square's cells,
    border included (8 x 8 for AprilTag 36h11), True where a cell is white.
    """

    id: int
    x: float
    y: float
    height: float
    facing: float
    size: float
    pattern: np.ndarray

    def __post_init__(self) -> None:
        pattern = np.asarray(self.pattern, dtype=bool)
        if pattern.ndim != 2 or pattern.shape[0] != pattern.shape[1] or pattern.shape[0] < 3:
            raise ValueError(f"marker {self.id}: the pattern must be a square of cells")
        if not (self.size > 0 and math.isfinite(self.size)):
            raise ValueError(f"marker {self.id}: the size must be positive")
        pattern.setflags(write=False)
        object.__setattr__(self, "pattern", pattern)

    @property
    def cell(self) -> float:
        """The side of one cell of the pattern, metres."""
        return self.size / self.pattern.shape[0]

    @property
    def outer(self) -> float:
        """The side of the white paper around the square, metres."""
        return self.cell * (self.pattern.shape[0] + 2 * QUIET_ZONE_CELLS)


def marker_pattern(dictionary: cv2.aruco.Dictionary, marker_id: int) -> np.ndarray:
    """The cells of marker `marker_id` of a cv2.aruco dictionary, with its one-cell black
    border: True where white. One pixel a cell, straight from OpenCV's own generator."""
    cells = dictionary.markerSize + 2
    image = cv2.aruco.generateImageMarker(dictionary, marker_id, cells, borderBits=1)
    return image > 127


class World:
    """Walls (and the markers on them) as arrays, ready for vectorised ray casting."""

    def __init__(self, walls: list[Wall], markers: Iterable[WorldMarker] = ()) -> None:
        # A world may have no walls: a floor plan of points and doors with no grid
        # either is an open floor, and the camera then sees floor and ceiling alone.
        self.walls = walls
        self.start = np.array([[w.x1, w.y1] for w in walls], dtype=np.float64).reshape(-1, 2)
        self.end = np.array([[w.x2, w.y2] for w in walls], dtype=np.float64).reshape(-1, 2)
        self.kind = np.array([w.kind for w in walls], dtype=np.int8)
        self.poster_at = np.array([w.poster_at for w in walls], dtype=np.float64)
        self.length = np.hypot(*(self.end - self.start).T)
        self.direction = (self.end - self.start) / np.maximum(self.length, 1e-12)[:, None]
        self.markers = tuple(markers)
        ids = [m.id for m in self.markers]
        if len(set(ids)) != len(ids):
            raise ValueError("two markers share an id")
        m = self.markers
        self.marker_centre = np.array([[k.x, k.y] for k in m], dtype=np.float64).reshape(-1, 2)
        facing = np.array([k.facing for k in m], dtype=np.float64)
        # The face's normal, and the way the printed image's columns run as seen by
        # someone facing it: to their right, which is the normal turned a quarter left.
        self.marker_normal = np.stack([np.cos(facing), np.sin(facing)], axis=-1)
        self.marker_right = np.stack([-np.sin(facing), np.cos(facing)], axis=-1)
        self.marker_height = np.array([k.height for k in m], dtype=np.float64)
        self.marker_outer = np.array([k.outer for k in m], dtype=np.float64)


def _room(x0: float, y0: float, x1: float, y1: float, door: tuple[str, float] | None,
          posters: dict[str, float]) -> list[Wall]:  # fmt: skip
    """A rectangle's four walls; `door` is (side, centre) of a 0.9 m doorway."""
    corners = {
        "south": (x0, y0, x1, y0), "east": (x1, y0, x1, y1),
        "north": (x1, y1, x0, y1), "west": (x0, y1, x0, y0),
    }  # fmt: skip
    walls = []
    for side, (ax, ay, bx, by) in corners.items():
        poster = posters.get(side, math.nan)
        if door is None or door[0] != side:
            walls.append(Wall(ax, ay, bx, by, WALL, poster))
            continue
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        a, b = door[1] - 0.45, door[1] + 0.45
        frame = 0.08
        walls += [
            Wall(ax, ay, ax + ux * (a - frame), ay + uy * (a - frame), WALL, poster),
            Wall(
                ax + ux * (a - frame), ay + uy * (a - frame), ax + ux * a, ay + uy * a, DOOR_FRAME
            ),
            Wall(
                ax + ux * b, ay + uy * b, ax + ux * (b + frame), ay + uy * (b + frame), DOOR_FRAME
            ),
            Wall(ax + ux * (b + frame), ay + uy * (b + frame), bx, by, WALL),
        ]
    return walls


def demo_world() -> World:
    """Two rooms joined by a doorway; the robot starts at the origin facing +x."""
    walls = _room(-2.0, -3.0, 6.0, 3.0, ("east", 3.0), {"north": 2.0, "south": 4.0, "west": 2.5})
    walls += _room(6.0, -3.0, 10.0, 3.0, ("west", 3.0), {"east": 1.5, "north": 1.0})
    return World(walls)
