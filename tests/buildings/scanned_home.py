"""A family home turned care home, as a SLAM scan of it leaves it, made a plan as a user
makes one: `giraff-console floorplan rooms home-map.yaml home.yaml`. The rooms come out
as `room-1`, `room-2`, ... and the plan has no outlines: its grid is the scan, cleared.

Unlike the example care home and unlike tests/planning/scanned_rooms.py's corridor of
rooms, it is a split plan on one level: the living side (a living room and a kitchen)
west of an L-shaped hall, and the bedroom side east of it, up a corridor 1.5 m wide; the
doors off the corridor and most others are 0.8 m, as in a house. Free floor in metres
(x right, y up), walls 0.15 m, d a door:

    y=12 +-------------+------+--------+-------+------+
         |             |office| bed 1  | bed 2 | bed 3|
         |             +--d---+---d----+--d----+--d---+ y=8.15
         |   living    d      d       corridor        |
         |             |      +--------+---d---+--d---+ y=6.35
         +----d--------+ hall |        |       |      |
         |             |      d  snug  | bath  | study|
         |   kitchen   |      |        +-------+------+ y=2.85
         |             d      +--------+              |
         |             |  hall's foot  d   utility    |
    y=0  +-------------+---------------+--------------+
        x=0            7    9.6       13.15          20

Furnished as a knee-high laser sees it (beds, wardrobes, sofas, kitchen counters and an
island, a desk, table and chair legs as specks), cluttered (boxes, bags and shoes along
the walls), with ragged wall faces and speckle (scanned_rooms' helpers), unknown all round
and a few free rays through the windows. One seeded generator draws it all. The 12 rooms
drawn come out as 12: the washing machines and a box left against the wall narrow the
utility room as a doorway does, and until issue 29 `floorplan rooms` split it there;
furniture makes no rooms now (floor_as_built.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.buildings.console import console_ok
from tests.planning.scanned_rooms import (
    FREE_SHADE,
    RESOLUTION,
    UNKNOWN_SHADE,
    WALL_M,
    WALL_SHADE,
    DrawnRoom,
    _Canvas,
    _furnish,
    _ragged,
    _speckle,
    write_scanned_map,
)

SEED = 25
SIZE_M = (22.5, 14.5)  # the map, from scanned_rooms.ORIGIN (1 m of unknown round)
Box = tuple[float, float, float, float]  # x0, y0, x1, y1, metres

# Free floor. The hall is an L: its stem north-south, its foot east along the south wall.
ROOMS: dict[str, tuple[Box, ...]] = {
    "kitchen": ((0.0, 0.0, 7.0, 4.35),),
    "living": ((0.0, 4.5, 7.0, 12.0),),
    "hall": ((7.15, 0.0, 9.6, 9.0), (9.6, 0.0, 13.0, 2.2)),
    "office": ((7.15, 9.15, 9.6, 12.0),),
    "snug": ((9.75, 2.35, 13.0, 6.35),),
    "corridor": ((9.75, 6.5, 20.0, 8.0),),
    "utility": ((13.15, 0.0, 20.0, 2.7),),
}
# Rooms off the corridor, furnished by scanned_rooms' `_furnish` as its rooms off its
# corridor are: a bed, a wardrobe, an armchair and a table; the bathroom its bath.
OFF_CORRIDOR = (
    DrawnRoom("bed-1", (9.75, 8.15, 13.5, 12.0), ((12.6, 0.8),)),
    DrawnRoom("bed-2", (13.65, 8.15, 16.9, 12.0), ((14.4, 0.8),)),
    DrawnRoom("bed-3", (17.05, 8.15, 20.0, 12.0), ((19.0, 0.8),)),
    DrawnRoom("bathroom", (13.15, 2.85, 16.0, 6.35), ((15.3, 0.8),)),
    DrawnRoom("study", (16.15, 2.85, 20.0, 6.35), ((17.0, 0.8),)),
)
# Doorways: centre in the middle of the wall, width, and whether the wall runs
# north-south (the doorway is crossed along x).
_ACROSS_X = [((7.075, 7.0), 1.2), ((7.075, 1.5), 0.8), ((9.675, 7.25), 0.9),
             ((9.675, 4.3), 0.8), ((13.075, 1.1), 0.8)]  # fmt: skip
_ACROSS_Y = [((2.0, 4.425), 0.9), ((8.4, 9.075), 0.8)] + [
    ((x, 8.075 if room.box[1] > 8 else 6.425), width)
    for room in OFF_CORRIDOR for x, width in room.doorways
]  # fmt: skip
DOORWAYS = [(centre, width, True) for centre, width in _ACROSS_X] + [
    (centre, width, False) for centre, width in _ACROSS_Y
]
# Furniture drawn solid (a laser sees a sofa's or a counter's side whole), clear of the
# ways between the doors.
FURNITURE: list[Box] = [
    (0.0, 7.0, 0.9, 9.6),  # the sofa along the living room's west wall
    (2.4, 11.2, 3.2, 12.0), (4.4, 11.2, 5.2, 12.0),  # two armchairs by the window
    (6.5, 9.6, 7.0, 11.4),  # the television's cabinet
    (0.0, 0.0, 5.0, 0.6), (0.0, 0.6, 0.6, 3.0),  # kitchen counters, an L
    (2.6, 1.9, 4.2, 2.6),  # the kitchen island
    (12.6, 2.8, 13.0, 5.6),  # the snug's bookcase
    (9.75, 5.5, 10.6, 6.35),  # its armchair
    (17.4, 0.0, 20.0, 0.6),  # washing machine, dryer and sink in the utility room
    (7.15, 11.4, 8.7, 12.0),  # the office's desk
    (7.15, 3.0, 7.5, 4.2),  # a shoe rack in the hall
]  # fmt: skip
# Tables and chairs, seen as the specks of their legs: centre and half the leg spacing.
LEGS = [((2.2, 8.3), 0.3), ((4.6, 6.2), 0.45), ((4.6, 5.3), 0.18), ((4.6, 7.1), 0.18),
        ((3.6, 6.2), 0.18), ((5.6, 6.2), 0.18), ((8.0, 10.8), 0.2)]  # fmt: skip


class _HomeCanvas(_Canvas):
    """scanned_rooms' canvas, the size of this home, keeping noise out of its doorways."""

    def __init__(self) -> None:
        self.cols = round(SIZE_M[0] / RESOLUTION)
        self.rows = round(SIZE_M[1] / RESOLUTION)
        self.image = np.full((self.rows, self.cols), UNKNOWN_SHADE, dtype=np.uint8)

    def near_doorways(self, margin: float = 0.2) -> np.ndarray:
        near = np.zeros(self.image.shape, dtype=bool)
        for (x, y), width, _ in DOORWAYS:
            row, col = self.cell(x, y)
            reach = round((width / 2 + margin) / RESOLUTION)
            near[row - reach : row + reach, col - reach : col + reach] = True
        return near


def home_image(seed: int = SEED) -> np.ndarray:
    """The map_server image: white free, black occupied, grey unknown, row 0 the top."""
    rng = np.random.default_rng(seed)
    canvas = _HomeCanvas()
    w = WALL_M
    canvas.box(-w, -w, 20 + w, 12 + w, WALL_SHADE)
    for box in [box for boxes in ROOMS.values() for box in boxes] + [r.box for r in OFF_CORRIDOR]:
        canvas.box(*box, FREE_SHADE)
    for (x, y), width, across_x in DOORWAYS:
        if across_x:
            canvas.box(x - w / 2, y - width / 2, x + w / 2, y + width / 2, FREE_SHADE)
        else:
            canvas.box(x - width / 2, y - w / 2, x + width / 2, y + w / 2, FREE_SHADE)
    _ragged(canvas, rng)
    for room in OFF_CORRIDOR:
        _furnish(canvas, room, rng)
    for box in FURNITURE:
        canvas.box(*box, WALL_SHADE)
    for (x, y), half in LEGS:
        for dx in (-half, half):
            for dy in (-half, half):
                canvas.disc(x + dx, y + dy, 0.025, WALL_SHADE)
    _clutter(canvas, rng)
    _speckle(canvas, rng)
    for x in (1.5, 5.0, 11.0, 15.0, 18.5):  # free rays through the north windows
        canvas.box(x, 12 + w, x + RESOLUTION, 12.9, FREE_SHADE)
    return canvas.image


def _clutter(canvas: _HomeCanvas, rng: np.random.Generator, count: int = 24) -> None:
    """Boxes, bags and shoes left on the floor against the walls, 0.15 to 0.35 m across:
    too big for the map's speck clearing, too close to a wall to be in the way."""
    near_door = canvas.near_doorways(0.6)
    image = canvas.image
    placed = 0
    while placed < count:
        x, y = rng.uniform(0.0, 20.0), rng.uniform(0.0, 12.0)
        size = rng.uniform(0.15, 0.35)
        row, col = canvas.cell(x, y)
        reach = round((size + 0.1) / RESOLUTION)
        around = image[row - reach : row + reach, col - reach : col + reach]
        touches_wall = (around == WALL_SHADE).any()
        if image[row, col] != FREE_SHADE or near_door[row, col] or not touches_wall:
            continue
        canvas.box(x - size / 2, y - size / 2, x + size / 2, y + size / 2, WALL_SHADE)
        placed += 1


def scanned_home(folder: Path, seed: int = SEED) -> Path:
    """The scan (`home-map.pgm` and `home-map.yaml`) written into `folder`, and its rooms
    found by `floorplan rooms` into `home.yaml` beside it (with `home-rooms.png`, the
    picture to check them by); the plan's path."""
    scan = write_scanned_map(folder, "home-map", home_image(seed))
    plan = folder / "home.yaml"
    console_ok("floorplan", "rooms", str(scan), str(plan), "--name", "Scanned home", "--force")
    return plan
