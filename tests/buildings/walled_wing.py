"""A care home of two wings round a hub, written by hand as a floor plan with room
outlines (floorplans/README.md), as a user writes one from a drawing; its grid is drawn
from the outlines, as the example's is (planning/rasterise.py).

Unlike the example care home (one rectangle, two parallel corridors), it sprawls: a west
wing 30 m long (a corridor 2.2 m wide with 15 rooms of 3 to 5 m either side and the dock),
a north wing 24 m long (a corridor 2 m wide, 11 rooms and a store, a sun lounge at its
end), a service corridor 1.6 m wide running 12 m south to a dead end with five small rooms
off it through 0.8 m doors, and an L-shaped day room of 120 m^2 east of the hub, with a
second door into the north wing's first room. 39 rooms; doors of 0.8 m (every third
bedroom's, the store's and the service rooms'), 0.9 m, and 1.2 to 1.8 m from the hub.
Metres, map frame; a sketch, not to scale, without the doors:

                         +-----------------------------+ y=38
                         |          sun lounge         |
                         +-----------+---+-------------+ y=32
                         | n-11      |   |        n-06 |
                         |  ...      | n |         ... |
                         | n-07      |   |        n-01 +---------+ y=12
                         | store     |   |             |   day   |
    +----------------+---+-----------+---+-------+-----+   room  |
    | w-01 ... w-08  |                           |         (an L,|
    +----------------+           hub             |       120 m^2)|
    |  west corridor             (x 0 to 8)                      |
    +----------------+---+                       |               |
    | w-09 ... w-15  |dock|   +---+---+----------+               |
    +----------------+----+   |   | s | sluice   +---------------+ y=-4
                     treatment|   | e | linen    |
                        stores|   | r | office   |
                              +---+---+----------+ y=-12
   x=-30                     -1   3  4.6         8              20
"""

from __future__ import annotations

from pathlib import Path

import cv2
import yaml

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.rasterise import grid_image, rasterise

Box = tuple[float, float, float, float]  # x0, y0, x1, y1

# The west wing's rooms, west to east: width, and the heading to arrive at (None: none).
WEST_NORTH = [(3.5, 90), (4.0, 90), (3.0, None), (5.0, 90), (3.5, 90), (4.0, None),
              (3.0, 90), (4.0, 90)]  # fmt: skip
WEST_SOUTH = [(4.0, 270), (3.5, None), (4.5, 270), (3.0, 270), (4.0, None), (5.0, 270),
              (3.0, 270)]  # fmt: skip
# The north wing's rooms, south to north: depth and heading.
NORTH_EAST = [(3.5, 0), (4.0, 0), (3.0, None), (5.0, 0), (4.5, 0), (4.0, None)]
NORTH_WEST = [(4.0, 180), (3.5, None), (5.0, 180), (4.0, 180), (5.5, 180)]
# The service corridor's rooms: name, box, and whether the door is in its west wall.
SERVICE = [("sluice", (4.6, -4.0, 8.0, 0.0), True), ("linen", (4.6, -8.0, 8.0, -4.0), True),
           ("office", (4.6, -12.0, 8.0, -8.0), True),
           ("treatment", (-1.0, -7.0, 3.0, -2.0), False),
           ("stores", (-1.0, -12.0, 3.0, -7.0), False)]  # fmt: skip


class _Plan:
    """The plan being written: rooms as boxes or outlines, and doors between them."""

    def __init__(self) -> None:
        self.rooms: dict[str, dict] = {}
        self.doors: list[dict] = []

    def room(self, name: str, label: str, outline: list[tuple[float, float]],
             at: tuple[float, float], heading: float | None = None) -> None:  # fmt: skip
        room: dict = {"label": label, "at": list(at)}
        if heading is not None:
            room["heading"] = heading
        room["outline"] = [list(corner) for corner in outline]
        self.rooms[name] = room

    def box(self, name: str, label: str, box: Box, heading: float | None = None,
            at: tuple[float, float] | None = None) -> None:  # fmt: skip
        """A rectangular room, its point in its middle unless `at` says otherwise."""
        x0, y0, x1, y1 = box
        middle = ((x0 + x1) / 2, (y0 + y1) / 2)
        self.room(name, label, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)], at or middle, heading)

    def door(self, a: str, b: str, at: tuple[float, float], width: float = 0.9) -> None:
        self.doors.append({"between": [a, b], "at": list(at), "width": width})


def wing_plan() -> dict:
    """The plan, as the mapping its YAML holds (without its grid)."""
    plan = _Plan()
    plan.box("hub", "Hub", (0, 0, 8, 8), heading=90, at=(4.0, 5.5))
    plan.box("west-corridor", "West corridor", (-30, 2.9, 0, 5.1), at=(-15.0, 4.0))
    plan.door("hub", "west-corridor", (0, 4.0), 1.8)
    x, number = -30.0, 1
    for width, heading in WEST_NORTH:
        name = f"w-{number:02}"
        plan.box(name, f"West {number}", (x, 5.1, x + width, 10), heading, at=(x + width / 2, 7.8))
        plan.door(name, "west-corridor", (x + 0.9, 5.1), 0.8 if number % 3 == 0 else 0.9)
        x, number = x + width, number + 1
    x = -30.0
    for width, heading in WEST_SOUTH:
        name = f"w-{number:02}"
        plan.box(name, f"West {number}", (x, -2, x + width, 2.9), heading, at=(x + width / 2, 0.2))
        plan.door(name, "west-corridor", (x + width - 0.9, 2.9), 0.8 if number % 3 == 0 else 0.9)
        x, number = x + width, number + 1
    plan.box("dock", "Charging dock", (x, -2, 0, 2.9), heading=270, at=(-1.5, 0.0))
    plan.door("dock", "west-corridor", (-1.5, 2.9))

    plan.box("north-corridor", "North corridor", (3, 8, 5, 32), at=(4.0, 20.0))
    plan.door("hub", "north-corridor", (4.0, 8), 1.8)
    plan.box("store", "Store", (0, 8, 3, 10))
    plan.door("store", "north-corridor", (3, 9.0), 0.8)
    y, number = 8.0, 1
    for depth, heading in NORTH_EAST:
        name = f"n-{number:02}"
        plan.box(name, f"North {number}", (5, y, 11, y + depth), heading, at=(8.5, y + depth / 2))
        plan.door(name, "north-corridor", (5, y + 1.0), 0.8 if number % 3 == 0 else 0.9)
        y, number = y + depth, number + 1
    y = 10.0
    for depth, heading in NORTH_WEST:
        name = f"n-{number:02}"
        plan.box(name, f"North {number}", (-1, y, 3, y + depth), heading, at=(0.5, y + depth / 2))
        plan.door(name, "north-corridor", (3, y + depth - 1.0), 0.8 if number % 3 == 0 else 0.9)
        y, number = y + depth, number + 1
    plan.box("sun-lounge", "Sun lounge", (-1, 32, 11, 38), heading=90, at=(4.0, 35.5))
    plan.door("north-corridor", "sun-lounge", (4.0, 32), 1.6)

    plan.box("service-corridor", "Service corridor", (3, -12, 4.6, 0), at=(3.8, -6.0))
    plan.door("hub", "service-corridor", (3.8, 0), 1.2)
    for name, box, west in SERVICE:
        plan.box(name, name.capitalize(), box, heading=0 if name == "office" else None)
        door_x = 4.6 if west else 3.0
        plan.door(name, "service-corridor", (door_x, (box[1] + box[3]) / 2), 0.8)

    day_room = [(8, -4), (20, -4), (20, 12), (14, 12), (14, 8), (8, 8)]
    plan.room("day-room", "Day room", day_room, (14.0, 2.0), heading=0)
    plan.door("hub", "day-room", (8, 4.0), 1.8)
    plan.door("day-room", "n-01", (9.5, 8), 0.9)  # a second way into the north wing
    return {"name": "Two wings round a hub", "rooms": plan.rooms, "doors": plan.doors,
            "start": "dock"}  # fmt: skip


HEADER = """\
# A care home of two wings round a hub, for issue 25's benchmark (tests/buildings/
# walled_wing.py). Metres, map frame; floorplans/README.md has the schema.
"""


def walled_wing(folder: Path) -> Path:
    """`wing.yaml` written into `folder`, with its grid `wing.pgm` drawn from its outlines
    beside it; the plan's path."""
    path = folder / "wing.yaml"
    plan = wing_plan()

    def write() -> None:
        path.write_text(HEADER + yaml.safe_dump(plan, sort_keys=False, default_flow_style=None))

    write()
    grid = rasterise(load_floorplan(path))
    image = folder / "wing.pgm"
    cv2.imwrite(str(image), grid_image(grid))
    plan["grid"] = {"image": image.name, "resolution": grid.resolution,
                    "origin": [grid.origin[0], grid.origin[1], 0.0]}  # fmt: skip
    write()
    return path
