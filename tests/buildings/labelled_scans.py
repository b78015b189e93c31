"""Buildings as a scan sees them, with the truth of which room each cell of floor is in:
the ground truth the room segmentation is measured on (issue 29; bench/segmentation.py,
tests/planning/test_segmentation_truth.py).

Each layout (labelled_layouts.py) is drawn twice with the same walls, ragged faces,
speckle and the same truth: bare, and furnished as a knee-high laser sees a lived-in
building (beds, wardrobes and counters against the walls, sofas, desks, tables as the
specks of their legs, a kitchen island, boxes and bags along the walls, a wheelchair
parked in a corridor, washing machines narrowing a utility room). The truth labels a
room's floor as built, under its furniture too, as Bormann et al.'s benchmark labels
it; the cells of a doorway between two rooms, the walls and the outside are 0. Walls
are 0.15 m, at 0.05 m a cell, in unknown space 1 m deep, with free rays through the
north windows. scanned_rooms.py's ragged faces and speckle are reused as they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np

from giraff_console.planning.grid import OccupancyGrid
from tests.buildings.labelled_layouts import FULL, Box, Layout, Opening, layout
from tests.planning.scanned_rooms import (
    FREE_SHADE,
    RESOLUTION,
    UNKNOWN_SHADE,
    WALL_M,
    WALL_SHADE,
    _Canvas,
    _ragged,
    _speckle,
)

MARGIN_M = 1.0  # unknown round the building
# Furnishings tried until one leaves the robot a way into every room: a room the route
# planner cannot reach is left out of any plan, and the truth would be no truth.
FURNISHINGS = 20
# The route planner keeps the robot's centre further than this from anything
# (route_planner.py: its radius and CLEARANCE_M).
REACH_M = 0.35


@dataclass(frozen=True)
class LabelledScan:
    name: str
    kind: str
    bare: np.ndarray  # map_server image: white free, black occupied, grey unknown
    furnished: np.ndarray  # the same, furnished and cluttered
    truth: np.ndarray  # int32 per cell: 1 + the room's index in `rooms`, 0 for none
    rooms: tuple[str, ...]
    origin: tuple[float, float]  # the lower-left corner, metres

    def grid(self, furnished: bool) -> OccupancyGrid:
        image = self.furnished if furnished else self.bare
        return OccupancyGrid.from_image(image, RESOLUTION, self.origin)

    def point_in(self, room: str) -> tuple[float, float]:
        """The centre of the cell of the room's floor, free in both versions, nearest
        the middle of that floor: where an operator stood to mark it."""
        label = self.rooms.index(room) + 1
        free = (self.truth == label) & (self.bare == FREE_SHADE) & (self.furnished == FREE_SHADE)
        rows, cols = np.nonzero(free)
        i = int(np.argmin(np.hypot(rows - rows.mean(), cols - cols.mean())))
        x = self.origin[0] + (cols[i] + 0.5) * RESOLUTION
        y = self.origin[1] + (self.truth.shape[0] - rows[i] - 0.5) * RESOLUTION
        return round(x, 3), round(y, 3)


class _Sheet(_Canvas):
    """scanned_rooms' canvas, the size of a layout, keeping noise out of its doors."""

    def __init__(self, plan: Layout) -> None:
        boxes = [space.box for space in plan.spaces]
        x0, y0 = min(b[0] for b in boxes) - MARGIN_M, min(b[1] for b in boxes) - MARGIN_M
        x1, y1 = max(b[2] for b in boxes) + MARGIN_M, max(b[3] for b in boxes) + MARGIN_M
        self.origin = (x0, y0)
        self.cols, self.rows = math.ceil((x1 - x0) / RESOLUTION), math.ceil((y1 - y0) / RESOLUTION)
        self.image = np.full((self.rows, self.cols), UNKNOWN_SHADE, dtype=np.uint8)
        self.doors: list[tuple[tuple[float, float], float]] = []

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return (self.rows - round((y - self.origin[1]) / RESOLUTION),
                round((x - self.origin[0]) / RESOLUTION))  # fmt: skip

    def near_doorways(self, margin: float = 0.2) -> np.ndarray:
        near = np.zeros(self.image.shape, dtype=bool)
        for (x, y), width in self.doors:
            row, col = self.cell(x, y)
            reach = round((width / 2 + margin) / RESOLUTION)
            near[max(0, row - reach) : row + reach, max(0, col - reach) : col + reach] = True
        return near

    def fill(self, target: np.ndarray, box: Box, value: int) -> None:
        r1, c0 = self.cell(box[0], box[1])
        r0, c1 = self.cell(box[2], box[3])
        target[r0:r1, c0:c1] = value


def _inner(box: Box, by: float = WALL_M / 2) -> Box:
    return box[0] + by, box[1] + by, box[2] - by, box[3] - by


def _cut(plan: Layout, opening: Opening) -> tuple[Box, tuple[float, float]]:
    """The free box an opening cuts through the wall two spaces share, and its centre."""
    a, b = plan.spaces[opening.a].box, plan.spaces[opening.b].box
    half = WALL_M / 2 + 0.01
    for across in (0, 1):  # 0: a wall running north-south, crossed along x
        along = 1 - across
        for wall in (a[across + 2], a[across]):
            if not (math.isclose(wall, b[across], abs_tol=1e-6)
                    or math.isclose(wall, b[across + 2], abs_tol=1e-6)):  # fmt: skip
                continue
            o0, o1 = max(a[along], b[along]), min(a[along + 2], b[along + 2])
            if o1 - o0 <= 0.5:
                continue
            if opening.width == FULL:
                s0, s1 = o0 + WALL_M / 2, o1 - WALL_M / 2
            else:
                width = min(opening.width, o1 - o0 - 2 * WALL_M)
                mid = o0 + opening.at * (o1 - o0)
                mid = min(max(mid, o0 + WALL_M + width / 2), o1 - WALL_M - width / 2)
                s0, s1 = mid - width / 2, mid + width / 2
            if across == 0:
                return (wall - half, s0, wall + half, s1), (wall, (s0 + s1) / 2)
            return (s0, wall - half, s1, wall + half), ((s0 + s1) / 2, wall)
    raise ValueError(f"{plan.name}: spaces {opening.a} and {opening.b} share no wall")


@cache
def labelled_scan(kind: str, seed: int) -> LabelledScan:
    """The map `kind`-`seed` of labelled_layouts.MAPS, drawn (once a process)."""
    from tests.buildings.furnishing import furnish  # the furniture, by the kind of room

    plan = layout(kind, seed)
    sheet = _Sheet(plan)
    rooms = tuple(dict.fromkeys(space.room for space in plan.spaces))
    truth = np.zeros(sheet.image.shape, dtype=np.int32)
    for space in plan.spaces:
        sheet.fill(sheet.image, _inner(space.box, -WALL_M / 2), WALL_SHADE)
    for space in plan.spaces:
        sheet.fill(sheet.image, _inner(space.box), FREE_SHADE)
        sheet.fill(truth, _inner(space.box), rooms.index(space.room) + 1)
    cuts: list[Box] = []
    for opening in plan.openings:
        box, centre = _cut(plan, opening)
        sheet.fill(sheet.image, box, FREE_SHADE)
        room_a, room_b = plan.spaces[opening.a].room, plan.spaces[opening.b].room
        if room_a == room_b:
            sheet.fill(truth, box, rooms.index(room_a) + 1)
        else:
            sheet.doors.append((centre, opening.width))
        cuts.append(box)
    for column in plan.columns:
        sheet.fill(sheet.image, column, WALL_SHADE)
        sheet.fill(truth, column, 0)
    rng = np.random.default_rng([29, seed, len(kind), 1])
    _ragged(sheet, rng)
    top = max(space.box[3] for space in plan.spaces)
    for space in plan.spaces:
        if math.isclose(space.box[3], top):
            x = (space.box[0] + space.box[2]) / 2
            sheet.fill(sheet.image, (x, top, x + RESOLUTION, top + 0.8), FREE_SHADE)
    bare = sheet.image.copy()
    for attempt in range(FURNISHINGS):
        sheet.image = bare.copy()
        furnish(sheet, plan, cuts, np.random.default_rng([29, seed, len(kind), 2, attempt]))
        if _robot_reaches_every_room(sheet.image, truth):
            break
    else:
        raise ValueError(f"{plan.name}: no furnishing of {FURNISHINGS} leaves every room reachable")
    furnished = sheet.image
    for image in bare, furnished:
        sheet.image = image
        _speckle(sheet, np.random.default_rng([29, seed, len(kind), 3]))
    return LabelledScan(plan.name, plan.kind, bare, furnished, truth, rooms, sheet.origin)


def _robot_reaches_every_room(image: np.ndarray, truth: np.ndarray) -> bool:
    """Whether the robot's centre can be planned (in one piece of the free space
    shrunk by the planner's reach) into every room of the truth."""
    free = (image == FREE_SHADE).astype(np.uint8)
    away = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    centres = (away > REACH_M / RESOLUTION + 1e-6).astype(np.uint8)
    _, pieces = cv2.connectedComponents(centres, connectivity=8)
    held = [set(np.unique(pieces[(truth == label) & (pieces > 0)]).tolist())
            for label in range(1, int(truth.max()) + 1)]  # fmt: skip
    return all(held) and bool(set.intersection(*held))
