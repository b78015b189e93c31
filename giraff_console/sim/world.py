"""The simulated world the synthetic camera sees: walls, door frames and posters.

A built-in demo world stands in until floor plans land: two rooms joined by a doorway,
with panelled walls, dark door frames and chequered posters, so that a corner detector
has something to find wherever the robot looks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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


class World:
    """Walls as arrays, ready for vectorised ray casting."""

    def __init__(self, walls: list[Wall]) -> None:
        if not walls:
            raise ValueError("a world needs walls")
        self.walls = walls
        self.start = np.array([[w.x1, w.y1] for w in walls], dtype=np.float64)
        self.end = np.array([[w.x2, w.y2] for w in walls], dtype=np.float64)
        self.kind = np.array([w.kind for w in walls], dtype=np.int8)
        self.poster_at = np.array([w.poster_at for w in walls], dtype=np.float64)
        self.length = np.hypot(*(self.end - self.start).T)


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
