"""A building as a user brings it from a scan: a map_server grid with walls, doorways,
furniture and speckle, and a floor plan of room points and doors with no outlines.

A corridor along the south (y 0 to 2 m) and three rooms north of it (west, middle and
east, each 4 m wide), every room with a doorway onto the corridor and the west and middle
rooms with one between them. Walls are 0.1 m thick; outside the building is unknown, as
a scan leaves it.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

RESOLUTION = 0.05
ORIGIN = (-0.5, -0.5)
SIZE_M = (13.0, 9.0)
FREE_SHADE, WALL_SHADE, UNKNOWN_SHADE = 254, 0, 205

# A points-and-doors plan, as a user writes one over a scan (floorplans/README.md).
PLAN = """\
name: Scanned home
rooms:
  corridor: {{label: Corridor, at: [6, 1]}}
  west-room: {{at: [2, 5], heading: 90}}
  middle-room: {{at: [6, 5]}}
  east-room: {{at: [10, 5]}}
doors:
  - {{between: [corridor, west-room], at: [2, 2.05], width: 1.0}}
  - {{between: [corridor, middle-room], at: [6, 2.05], width: 1.0}}
  - {{between: [corridor, east-room], at: [10, 2.05], width: 1.0}}
  - {{between: [west-room, middle-room], at: [4.05, 5], width: 0.9, id: connecting}}
grid:
  image: {image}
  resolution: {resolution}
  origin: [{origin_x}, {origin_y}, 0.0]
start: corridor
"""


def scanned_image() -> np.ndarray:
    """The map_server image: white free, black occupied, grey unknown, row 0 the top."""
    cols, rows = round(SIZE_M[0] / RESOLUTION), round(SIZE_M[1] / RESOLUTION)
    image = np.full((rows, cols), UNKNOWN_SHADE, dtype=np.uint8)

    def fill(x0: float, y0: float, x1: float, y1: float, shade: int) -> None:
        c0, c1 = round((x0 - ORIGIN[0]) / RESOLUTION), round((x1 - ORIGIN[0]) / RESOLUTION)
        r1, r0 = (rows - round((y - ORIGIN[1]) / RESOLUTION) for y in (y0, y1))
        image[r0:r1, c0:c1] = shade

    fill(0, 0, 12, 8, FREE_SHADE)
    for x0, y0, x1, y1 in [
        (-0.1, -0.1, 12.1, 0.0), (-0.1, 8.0, 12.1, 8.1),  # south and north
        (-0.1, -0.1, 0.0, 8.1), (12.0, -0.1, 12.1, 8.1),  # west and east
        (0.0, 2.0, 12.0, 2.1),  # the corridor's north wall
        (4.0, 2.1, 4.1, 8.0), (8.0, 2.1, 8.1, 8.0),  # between the rooms
    ]:  # fmt: skip
        fill(x0, y0, x1, y1, WALL_SHADE)
    for x in (2.0, 6.0, 10.0):  # doorways onto the corridor, 1.0 m wide
        fill(x - 0.5, 2.0, x + 0.5, 2.1, FREE_SHADE)
    fill(4.0, 4.55, 4.1, 5.45, FREE_SHADE)  # west-room to middle-room, 0.9 m
    # Furniture: a bed, a table, a wardrobe, each well off the ways between the doors.
    fill(0.3, 6.3, 1.2, 7.7, WALL_SHADE)
    fill(6.8, 6.6, 7.6, 7.4, WALL_SHADE)
    fill(11.3, 3.0, 11.9, 4.0, WALL_SHADE)
    # Speckle a scan leaves: single occupied cells in corners, unknown ones on the floor.
    for x, y in [(0.1, 0.1), (11.85, 0.15), (0.15, 2.25), (11.8, 7.8), (7.85, 7.85)]:
        fill(x, y, x + RESOLUTION, y + RESOLUTION, WALL_SHADE)
    for x, y in [(3.0, 1.5), (9.0, 0.5), (5.0, 3.5), (10.5, 6.5)]:
        fill(x, y, x + RESOLUTION, y + RESOLUTION, UNKNOWN_SHADE)
    return image


def write_scanned_plan(
    folder: Path, plan: str = PLAN, name: str = "scanned", **fields: str
) -> Path:
    """The plan and its PGM written into `folder`; the plan's path. `plan` is formatted
    with the grid's image, resolution and origin, and `fields`."""
    image = folder / f"{name}.pgm"
    cv2.imwrite(str(image), scanned_image())
    path = folder / f"{name}.yaml"
    grid = {"image": image.name, "resolution": RESOLUTION, "origin_x": ORIGIN[0]}
    path.write_text(plan.format(**grid, origin_y=ORIGIN[1], **fields))
    return path
