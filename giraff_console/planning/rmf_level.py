"""One level of an Open-RMF building map, as the importer works from it.

rmf_import.py reads the map and checks it; what it hands on is here, in metres in the
map frame: the vertices, the named ones (the rooms to be), the lanes of the fleets chosen,
the doors, walls, floors and holes. Each item keeps where it is in the file (`where`), so
that whatever becomes of it can be told at its line.

`Places` is the graph the rooms are found on (rmf_spaces.py): the free cells of the
floor between walls (rmf_walls.py), or the points along the lanes on a level without
walls (rmf_lanes.py). Both are the same kind of graph, so that finding rooms, joining
them and choosing where passages go is done once for both.
"""

from __future__ import annotations

import math
from collections.abc import Container
from dataclasses import dataclass
from typing import Any

import numpy as np

from giraff_console.planning.floorplan import Point, Where

ID_LENGTH = 64  # as floorplan.py allows: ids are typed in commands


def numbered(stem: str, count: int) -> str:
    """`stem` with `-count` after it, within an id's length ("waiting_area-2")."""
    return f"{stem[: ID_LENGTH - len(str(count)) - 1]}-{count}"


def free_id(stem: str, taken: Container[str], plain: bool = True) -> str:
    """The first id not `taken` of `stem` (cut to an id's length; unless not `plain`),
    `stem-2`, `stem-3`, ... (`stem-1` first when not `plain`: "space-1")."""
    count = 1
    found = stem[:ID_LENGTH] if plain else numbered(stem, count)
    while found in taken:
        count += 1
        found = numbered(stem, count)
    return found


@dataclass(frozen=True)
class Named:
    """A named vertex: a room of the floor plan."""

    id: str  # the room id, made from the name (and renamed if another vertex has it)
    name: str  # as the map names it
    vertex: int
    at: Point
    charger: bool  # RMF's is_charger: where a robot docks, so where ours starts
    where: Where


@dataclass(frozen=True)
class RmfDoor:
    id: str  # the door's name made an id (and renamed if it clashes)
    ends: tuple[Point, Point]
    where: Where

    @property
    def centre(self) -> Point:
        (x1, y1), (x2, y2) = self.ends
        return ((x1 + x2) / 2, (y1 + y2) / 2)

    @property
    def width(self) -> float:
        return math.dist(*self.ends)

    @property
    def normal(self) -> Point:
        """The unit vector square to the door, to its left from its first end to its
        second; (0, 0) for a door of no width."""
        (px, py), (qx, qy) = self.ends
        width = self.width
        return (-(qy - py) / width, (qx - px) / width) if width else (0.0, 0.0)

    def on_left(self, point: Point) -> bool:
        """Whether `point` is on the door's left, from its first end to its second."""
        (px, py), (qx, qy) = self.ends
        return (qx - px) * (point[1] - py) - (qy - py) * (point[0] - px) > 0


@dataclass(frozen=True)
class Lane:
    ends: tuple[int, int]  # vertex indices; every lane counts both ways
    where: Where


@dataclass(frozen=True)
class Level:
    points: list[Point]  # every vertex, metres in the map frame
    named: list[Named]  # in the file's order
    lanes: list[Lane]  # of the graphs chosen
    doors: list[RmfDoor]
    walls: list[tuple[int, int]]
    floors: list[list[Point]]  # polygons
    holes: list[list[Point]]  # polygons cut out of the floors


@dataclass(frozen=True)
class Places:
    """Places the robot can be, joined to their neighbours: the graph rooms are found on."""

    xy: np.ndarray  # (n, 2): each place, metres in the map frame
    links: Any  # (n, n) scipy csr_array, symmetric: metres between neighbouring places
    space: np.ndarray  # (n,) which space each place is in (walls and doors bound spaces)
    clearance: np.ndarray  # (n,) metres to the nearest wall; inf without walls
    step: float  # metres between neighbouring places, about

    def nearest(self, point: Point, space: int, need: float) -> int | None:
        """The place of `space` nearest `point` with at least `need` metres clear of the
        walls; None if there is none."""
        found = np.flatnonzero((self.space == space) & (self.clearance >= need))
        if not found.size:
            return None
        away = np.hypot(self.xy[found, 0] - point[0], self.xy[found, 1] - point[1])
        return int(found[np.argmin(away)])

    def centre(self, space: int) -> int:
        """The most interior place of `space`: of the places nearly as far from the walls
        as any, the one nearest the middle of the space (without walls, that one)."""
        found = np.flatnonzero(self.space == space)
        clear = self.clearance[found]
        best = found[clear >= clear.max() - self.step]  # inf - step is inf: all of them
        middle = self.xy[found].mean(axis=0)
        away = np.hypot(self.xy[best, 0] - middle[0], self.xy[best, 1] - middle[1])
        return int(best[np.argmin(away)])
