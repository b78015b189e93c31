"""A picture of the rooms `floorplan rooms` found in a scan, for a person to check.

The segmentation is a guess (room_segmentation.py), and a plan's room names are only
useful once someone has matched them to the building. So the command draws what it
found over the scan: the grid in greys as map_server draws it, each room's floor tinted
(no two rooms with a door between them alike), its name written over a dot at its
point, where `go` takes the robot, and each door as a dark red bar from jamb to jamb.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN
from giraff_console.planning.room_segmentation import Segmentation
from giraff_console.planning.walls import grid_jambs

Colour = tuple[int, int, int]  # blue, green, red, as OpenCV writes them

# Light enough for black text on them, unlike each other (ColorBrewer's Set3, with a
# light blue for its grey, which would pass for the scan's own floor).
PALETTE: tuple[Colour, ...] = (
    (199, 211, 141), (179, 255, 255), (218, 186, 190), (114, 128, 251),
    (211, 177, 128), (98, 180, 253), (105, 222, 179), (229, 205, 252),
    (227, 206, 166), (189, 128, 188), (197, 235, 204), (111, 237, 255),
)  # fmt: skip
SHADES = {FREE: 240, OCCUPIED: 40, UNKNOWN: 160}
DOOR_COLOUR: Colour = (0, 0, 170)
# Pictures are drawn at least this wide (in whole pixels a cell), so that the names can
# be read; a grid wider than this is drawn a pixel a cell.
MIN_WIDTH_PX = 1200
MAX_SCALE = 8


def picture_scale(shape: tuple[int, int]) -> int:
    """Pixels a grid cell is drawn as, on a side, for a grid of `shape` (rows, columns)."""
    return max(1, min(MAX_SCALE, math.ceil(MIN_WIDTH_PX / shape[1])))


def room_colours(segmentation: Segmentation) -> dict[str, Colour]:
    """The colour each room's floor is drawn in: the palette in room order, skipping a
    colour a room it has a door to has already."""
    neighbours: dict[str, set[str]] = {room.id: set() for room in segmentation.rooms}
    for door in segmentation.doors:
        a, b = door.between
        neighbours[a].add(b)
        neighbours[b].add(a)
    colours: dict[str, Colour] = {}
    for number, room in enumerate(segmentation.rooms):
        taken = {colours[other] for other in neighbours[room.id] if other in colours}
        for step in range(len(PALETTE)):
            colour = PALETTE[(number + step) % len(PALETTE)]
            if colour not in taken:
                break
        colours[room.id] = colour
    return colours


def draw_rooms(segmentation: Segmentation) -> np.ndarray:
    """The picture, as an OpenCV BGR image `picture_scale` pixels to a cell."""
    grid = segmentation.grid
    grey = np.zeros(grid.shape, dtype=np.uint8)
    for state, shade in SHADES.items():
        grey[grid.cells == state] = shade
    image = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    free = grid.cells == FREE
    colours = room_colours(segmentation)
    for room in segmentation.rooms:
        image[(segmentation.labels == room.label) & free] = colours[room.id]
    scale = picture_scale(grid.shape)
    image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)

    def pixel(x: float, y: float) -> tuple[int, int]:
        row, col = grid.cell_of(x, y)
        return col * scale + scale // 2, row * scale + scale // 2

    for door in segmentation.doors:
        jambs = grid_jambs(grid, door)
        if jambs is not None:
            cv2.line(image, pixel(*jambs[0]), pixel(*jambs[1]), DOOR_COLOUR, max(3, 2 * scale))
        else:
            cv2.circle(image, pixel(*door.at), max(3, scale * 2), DOOR_COLOUR, -1)
    font, size = cv2.FONT_HERSHEY_SIMPLEX, max(0.4, 0.2 * scale)
    for room in segmentation.rooms:
        x, y = pixel(*room.at)
        cv2.circle(image, (x, y), max(2, scale), (0, 0, 0), -1)
        (width, height), _ = cv2.getTextSize(room.id, font, size, 1)
        left = min(max(0, x - width // 2), image.shape[1] - width)
        base = max(height, y - max(4, 2 * scale))
        # A white edge round black letters: legible on any tint, and over walls.
        cv2.putText(image, room.id, (left, base), font, size, (255, 255, 255), 3, cv2.LINE_AA)
        cv2.putText(image, room.id, (left, base), font, size, (0, 0, 0), 1, cv2.LINE_AA)
    return image


def encode_png(image: np.ndarray) -> bytes:
    """The picture as PNG bytes, to be written once everything else has been."""
    done, data = cv2.imencode(".png", image)
    if not done:
        raise OSError("OpenCV could not encode the picture as PNG")
    return data.tobytes()
