"""Doors between the rooms `floorplan rooms` found in a scan, and the ones the robot can
pass as the route planner plans it.

Two rooms found (room_segmentation.py) meet where the way between them is narrowest: a
doorway. Each stretch of border between two rooms is one, placed half-way between its
jambs and as wide as the free space between them.

A doorway is only a door if `plan` and `go` can take the robot through it. The route
planner (route_planner.py) keeps the robot's centre further than its radius and
CLEARANCE_M from every cell that is not free, unknown ones too, so a doorway is passable
when some cell of it is that far from any other: the same test as the planner's
inflation, on the same grid. And each room's point must reach its doors across the
room: furniture can shut a room's point off from a doorway that is wide enough, so the
planner's own legs are measured from each room's point to each of its doors. Rooms the
robot cannot reach that way from the biggest group of rooms are left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import Door, FloorPlan, Point, Room
from giraff_console.planning.grid import FREE, OccupancyGrid
from giraff_console.planning.plan_writing import millimetres
from giraff_console.planning.route_planner import CLEARANCE_M, RoutePlanner
from giraff_console.planning.walls import grid_jambs

# The clearance is float32 cells times the resolution: 7 cells of 0.05 m come to
# 0.35000000000000003 m, which the planner's inflation (7 cells or less is blocked) is
# not. A micrometre more than the reach settles it the planner's way.
_MARGIN_M = 1e-6

Cells = tuple[np.ndarray, np.ndarray]  # rows and columns


@dataclass(frozen=True)
class Doorway:
    rooms: tuple[int, int]  # the two rooms' labels
    at: Point  # half-way between its jambs
    width: float  # the free space between the jambs' faces
    clearance: float  # the most room the robot has in it: metres to the nearest wall


def least_clearance(robot_radius: float) -> float:
    """How far from the nearest cell that is not free a cell must be, more than, to be
    free to the route planner for a robot of `robot_radius`."""
    return robot_radius + CLEARANCE_M + _MARGIN_M


def cells_of(labels: np.ndarray) -> dict[int, Cells]:
    """Each room's cells, by label, found in one pass over the grid."""
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    order = np.argsort(ids, kind="stable")
    ids, rows, cols = ids[order], rows[order], cols[order]
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]]) if len(ids) else np.array([], int)
    ends = np.r_[starts[1:], len(ids)]
    return {int(ids[s]): (rows[s:e], cols[s:e]) for s, e in zip(starts, ends, strict=True)}


def doorways(grid: OccupancyGrid, labels: np.ndarray, clearance: np.ndarray) -> list[Doorway]:
    """Where each two rooms meet, once for each separate stretch of their border, so that
    a room with two doorways onto a corridor has two. The doorway is measured from the
    widest point of the stretch, which the flood put where the way is narrowest."""
    rows, cols = labels.shape
    border: dict[tuple[int, int], list[Cells]] = {}
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        # Each cell against its neighbour to the right, below, and diagonally below.
        left, right = max(0, -dc), max(0, dc)
        here = labels[: rows - dr, left : cols - right]
        there = labels[dr:, right : cols - left]
        r, c = np.nonzero((here > 0) & (there > 0) & (here != there))
        low = np.minimum(here[r, c], there[r, c])
        high = np.maximum(here[r, c], there[r, c])
        for key in set(zip(low.tolist(), high.tolist(), strict=True)):
            pick = (low == key[0]) & (high == key[1])
            border.setdefault(key, []).append((r[pick], c[pick] + left))
            border[key].append((r[pick] + dr, c[pick] + right))
    found: list[Doorway] = []
    for (a, b), pieces in border.items():
        # The border drawn in its own box, to be cut into its separate stretches.
        r = np.concatenate([piece[0] for piece in pieces])
        c = np.concatenate([piece[1] for piece in pieces])
        top, left = r.min(), c.min()
        drawn = np.zeros((r.max() - top + 1, c.max() - left + 1), dtype=np.uint8)
        drawn[r - top, c - left] = 1
        count, stretches = cv2.connectedComponents(drawn, connectivity=8)
        for stretch in range(1, count):
            on = np.argwhere(stretches == stretch) + np.array([top, left])
            best = on[int(np.argmax(clearance[on[:, 0], on[:, 1]]))]
            cell = (int(best[0]), int(best[1]))
            at, width = _doorway(grid, clearance, cell)
            found.append(Doorway((a, b), at, width, float(clearance[cell])))
    return found


def _doorway(
    grid: OccupancyGrid, clearance: np.ndarray, cell: tuple[int, int]
) -> tuple[Point, float]:
    """The centre and free width of the doorway whose widest point on the border between
    two rooms is `cell`: half-way between its jambs, the occupied cells either side (as
    the route planner finds them, walls.py), and the space between their faces."""
    x, y = grid.centre_of(*cell)
    guess = Door("", ("", ""), (x, y), 2 * float(clearance[cell]), True)
    jambs = grid_jambs(grid, guess)
    if jambs is None:
        return (millimetres(x), millimetres(y)), millimetres(guess.width)
    (ax, ay), (bx, by) = jambs
    middle = ((ax + bx) / 2, (ay + by) / 2)
    width = math.dist(jambs[0], jambs[1]) - grid.resolution  # centres to faces
    row, col = grid.cell_of(*middle)
    if grid.cells[row, col] != FREE:
        middle = (x, y)
    return (millimetres(middle[0]), millimetres(middle[1])), millimetres(width)


def passable(
    grid: OccupancyGrid,
    points: dict[int, Point],
    sizes: dict[int, int],
    found: list[Doorway],
    robot_radius: float,
) -> tuple[set[int], list[Doorway]]:
    """The rooms the robot can be planned between, and the doorways it is planned
    through: of the groups of rooms (by label, each at its point, of `sizes` cells) that
    passable doorways join, the one of the most rooms (the most floor, if several are as
    many).

    A doorway is passable when the planner's grid is free at its widest point and the
    planner finds a way from each room's point to it. Those ways are planned in a window
    round the room's point and doors (legs.py), so they are measured again whenever rooms
    or doorways have been left out, until none is."""
    rooms = set(points)
    doors = [door for door in found if door.clearance > least_clearance(robot_radius)]
    while True:
        plan = FloorPlan(
            "",
            {str(label): Room(str(label), str(label), points[label], None, None)
             for label in rooms},
            [Door(str(i), (str(door.rooms[0]), str(door.rooms[1])), door.at, door.width, True)
             for i, door in enumerate(doors)],
            None, None, Path(),
        )  # fmt: skip
        legs = RoutePlanner(plan, grid, robot_radius).legs
        assert legs is not None  # planned on a grid
        ways = [
            door
            for door in doors
            if all(legs.length(points[room], door.at, str(room)) is not None for room in door.rooms)
        ]
        group = _biggest_group({label: sizes[label] for label in rooms}, ways)
        ways = [door for door in ways if door.rooms[0] in group]
        if group == rooms and len(ways) == len(doors):
            return rooms, doors
        rooms, doors = group, ways


def _biggest_group(sizes: dict[int, int], doors: list[Doorway]) -> set[int]:
    """The rooms joined by `doors` to the most others (the most floor, if several groups
    are as many): a plan must reach every room from its start."""
    group = {label: {label} for label in sizes}
    for door in doors:
        a, b = door.rooms
        if group[a] is not group[b]:
            merged = group[a] | group[b]
            for label in merged:
                group[label] = merged
    groups = {id(rooms): rooms for rooms in group.values()}.values()
    return max(groups, key=lambda rooms: (len(rooms), sum(sizes[room] for room in rooms)))
