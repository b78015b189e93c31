"""A small flat for teaching by driving (issue 29): a building the console has never
seen, to be mapped with the range sensor as the operator drives it.

Unlike the example care home it is furnished, its doors are 0.8 m, and the console is
given no plan of it: the simulator is put in it with `--sim-building`, and the console
starts on a plan of the dock alone (`unmapped_plan`). Free floor in metres (x right,
y up), walls 0.15 m, d a door 0.8 m wide:

    y=6  +-----------+---------+
         | sofa      |   bed   |
         |   lounge  |bedroom  |
         |   (table) |     wrd +----------+ y=3
         +----d------+---d-----+ kitchen  |
         |  hall (dock at west end)  d    | (counters east)
    y=0  +---------------------+----------+
        x=0         4.5       8          11

The truth is drawn as a ROS map_server grid (walls and furniture occupied, floor free,
unknown outside), with a plan of its four rooms' points and its three doors for the
simulator's walls and the operator's way round.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import Landmarks

RESOLUTION = 0.05
ORIGIN = (-1.0, -1.0)
SIZE_M = (13.0, 8.0)
WALL_M = 0.15
DOOR_M = 0.8
DOCK = (0.6, 0.75, 0.0)  # x, y, heading (degrees) of the dock, in the hall
ROOMS = {
    "hall": (0.6, 0.75),  # the start room: its point is the dock's
    "lounge": (2.6, 2.7),
    "bedroom": (6.0, 2.6),
    "kitchen": (9.4, 1.5),
}
# (between, centre, across x): a door in a wall running along x (across_x False: the
# wall runs along y).
DOORS = (
    (("hall", "lounge"), (2.0, 1.575), True),
    (("hall", "bedroom"), (6.6, 1.575), True),
    (("hall", "kitchen"), (8.075, 0.9), False),
)
# Furniture as a knee-high laser sees it: solid boxes (x0, y0, x1, y1).
FURNITURE = (
    (0.0, 3.6, 0.9, 5.6),  # the lounge's sofa, against the west wall
    (2.4, 3.8, 3.4, 4.4),  # its coffee table
    (5.4, 4.1, 6.9, 6.0),  # the bed, against the north wall
    (7.4, 2.0, 8.0, 3.0),  # the wardrobe
    (10.4, 0.0, 11.0, 2.4),  # the kitchen's counters, along its east wall
)
FREE, OCCUPIED, UNKNOWN = 254, 0, 205


def _cell(x: float, y: float, rows: int) -> tuple[int, int]:
    return rows - 1 - math.floor((y - ORIGIN[1]) / RESOLUTION), math.floor(
        (x - ORIGIN[0]) / RESOLUTION
    )


def flat_image() -> np.ndarray:
    """The flat as its truth: walls and furniture 0, floor 254, unknown 205 outside."""
    cols, rows = round(SIZE_M[0] / RESOLUTION), round(SIZE_M[1] / RESOLUTION)
    image = np.full((rows, cols), UNKNOWN, np.uint8)

    def box(x0: float, y0: float, x1: float, y1: float, shade: int) -> None:
        r1, c0 = _cell(x0, y0, rows)
        r0, c1 = _cell(x1 - 1e-9, y1 - 1e-9, rows)
        image[r0 : r1 + 1, c0 : c1 + 1] = shade

    w = WALL_M
    # The building's outline, walls and all, then the floor of each room inside.
    box(-w, -w, 8.0 + w, 6.0 + w, OCCUPIED)
    box(8.0, -w, 11.0 + w, 3.0 + w, OCCUPIED)
    box(0.0, 0.0, 8.0, 1.5, FREE)  # hall
    box(0.0, 1.5 + w, 4.5, 6.0, FREE)  # lounge
    box(4.5 + w, 1.5 + w, 8.0, 6.0, FREE)  # bedroom
    box(8.0 + w, 0.0, 11.0, 3.0, FREE)  # kitchen
    for _, (x, y), across_x in DOORS:
        if across_x:
            box(x - DOOR_M / 2, y - w, x + DOOR_M / 2, y + w, FREE)
        else:
            box(x - w, y - DOOR_M / 2, x + w, y + DOOR_M / 2, FREE)
    for furniture in FURNITURE:
        box(*furniture, OCCUPIED)
    return image


PLAN = """\
# A small furnished flat: the truth the simulator is put in (tests/teaching/flat.py).
name: A small flat (truth)
grid:
  image: flat.pgm
  resolution: {resolution}
  origin: [{ox}, {oy}, 0.0]
  negate: 0
  occupied_thresh: 0.65
  free_thresh: 0.196
rooms:
{rooms}
doors:
{doors}
start: hall
"""


def write_flat(folder: Path) -> Path:
    """The flat's grid and plan written into `folder`; the plan's path."""
    cv2.imwrite(str(folder / "flat.pgm"), flat_image())
    rooms = []
    for name, (x, y) in ROOMS.items():
        heading = f", heading: {DOCK[2]:g}" if name == "hall" else ""
        rooms.append(f"  {name}: {{at: [{x}, {y}]{heading}}}")
    doors = [
        f"  - {{between: [{a}, {b}], at: [{x}, {y}], width: {DOOR_M}, id: {a}-{b}}}"
        for (a, b), (x, y), _ in DOORS
    ]
    path = folder / "flat.yaml"
    path.write_text(PLAN.format(resolution=RESOLUTION, ox=ORIGIN[0], oy=ORIGIN[1],
                                rooms="\n".join(rooms), doors="\n".join(doors)))  # fmt: skip
    return path


UNMAPPED = """\
# A building not mapped yet: only the dock, where the robot stands now, and the markers
# staff put up (their family and size; where they hang is to be learnt).
name: Not mapped yet
rooms:
  dock: {{at: [{x}, {y}], heading: {heading}}}
doors: []
start: dock
"""
MARKERS = """\
landmarks:
  family: {family}
  size: {size}
  markers: []
"""


def unmapped_plan(folder: Path, dock: tuple[float, float, float] = DOCK,
                  markers: Landmarks | None = None) -> Path:  # fmt: skip
    """The plan a console maps a new building from: the dock alone, at `dock`, and the
    family and size of the building's `markers`, if it has any."""
    path = folder / "unmapped.yaml"
    text = UNMAPPED.format(x=dock[0], y=dock[1], heading=dock[2])
    if markers is not None:
        text += MARKERS.format(family=markers.family, size=markers.size)
    path.write_text(text)
    return path
