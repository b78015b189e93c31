"""A clinic's ground floor as an Open-RMF traffic-editor map, imported as a user imports
one: `giraff-console floorplan import clinic.building.yaml clinic.yaml --level L1`. The
plan has no outlines and no headings; its grid is drawn from the map's walls.

Unlike the example care home (a 48 m by 22 m rectangle of straight corridors), the clinic
is an L: a corridor 2.2 m wide runs 22 m east from the waiting hall, bends, and runs 20
m north to a day room, with treatment and consulting rooms along the first leg and wards
along the second. Doors are 0.9 to 1.0 m, the waiting hall's and the day room's 1.8 m
double doors; wards A and B have a door between them. Design metres (x right, y up; the
map frame's y is this y less rmf_buildings.HEIGHT_M), d a door:

    y=34                      +----------------+
                              |    day room    |
    y=28               +------+------d---------+--+
                       | ward B  d  |  | d ward D  |
                       +---d--------+  +-----------+ y=21
                       | ward A  d  |  | d ward C  |
    y=14 +---------+---+-----+------+  +-----------+
         |         | con 1 | con 2 | pharmacy |  | d staff room|
         | waiting d---d-----+--d----+----d-----+  |            |
         |  hall   d       main corridor          bend         |
         |         +--d--+--d--+--d--+--d--+--d--+---------+---+ y=6
         |         | T 1 | T 2 | T 3 | T 4 |   store    |
    y=0  +---------+-----+-----+-----+-----+------------+
        x=0       10    15    20    25    30   32.2    36    40

The hall also opens into consulting room 1. One fleet's lanes run down the middle of the
corridor and through every door; a charger in the hall is where the robot starts.
"""

from __future__ import annotations

from pathlib import Path

from tests.buildings.console import console_ok
from tests.planning.rmf_buildings import Level, Point, one_level

CORRIDOR_Y = 7.1  # the middle of the first leg, y 6 to 8.2
WARD_X = 31.1  # the middle of the second leg, x 30 to 32.2

# Rooms off the first leg: name, where its vertex is, and its door across the corridor's
# south (y 6) or north (y 8.2) wall, x from and to.
SOUTH_ROOMS = [("treatment_1", (12.5, 3.0), (12.0, 12.9)),
               ("treatment_2", (17.5, 3.0), (17.0, 17.95)),
               ("treatment_3", (22.5, 3.0), (22.0, 22.9)),
               ("treatment_4", (27.5, 3.0), (27.0, 28.0)),
               ("store", (33.0, 3.0), (30.9, 31.8))]  # fmt: skip
NORTH_ROOMS = [("consulting_1", (13.0, 11.0), (12.5, 13.4)),
               ("consulting_2", (19.0, 11.0), (18.5, 19.5)),
               ("pharmacy", (26.0, 11.0), (25.5, 26.4))]  # fmt: skip
# Rooms off the second leg: name, vertex, and its door across the corridor's west (x 30)
# or east (x 32.2) wall, y from and to.
WEST_ROOMS = [("ward_a", (25.0, 17.5), (17.0, 18.0)),
              ("ward_b", (25.0, 24.5), (24.0, 24.95))]  # fmt: skip
EAST_ROOMS = [("staff_room", (36.0, 10.0), (10.5, 11.4)),
              ("ward_c", (36.0, 17.5), (17.0, 17.9)),
              ("ward_d", (36.0, 24.5), (24.0, 25.0))]  # fmt: skip
OUTSIDE: list[Point] = [(0, 0), (36, 0), (36, 6), (40, 6), (40, 28), (38, 28), (38, 34),
                        (24, 34), (24, 28), (20, 28), (20, 14), (0, 14), (0, 0)]  # fmt: skip


def clinic_level() -> Level:
    """Level L1 of the clinic, drawn as traffic-editor users draw: walls ending at the
    doors in them, one floor polygon, a fleet's lanes through every door."""
    level = Level()
    level.wall(*OUTSIDE)
    level.floors.append(OUTSIDE[:-1])
    level.wall((10, 0), (10, 14))  # the waiting hall's east wall
    level.wall((10, 6), (36, 6))  # the corridor's south wall, and the store's north
    level.wall((10, 8.2), (30, 8.2))  # its north wall, to the bend
    for x in (15, 20, 25, 30):
        level.wall((x, 0), (x, 6))  # between the treatment rooms and the store
    for x in (16, 22):
        level.wall((x, 8.2), (x, 14))  # between the consulting rooms and the pharmacy
    level.wall((20, 14), (30, 14))  # the pharmacy's north wall, ward A's south
    level.wall((30, 8.2), (30, 28))  # the second leg's west wall
    level.wall((32.2, 6), (32.2, 28))  # its east wall
    level.wall((20, 21), (30, 21))
    level.wall((32.2, 14), (40, 14))
    level.wall((32.2, 21), (40, 21))
    level.wall((24, 28), (38, 28))  # the day room's south wall

    n, p = level.named, level.path
    level.door("hall_door", (10, 6.2), (10, 8.0), "double_hinged")
    level.door("hall_consulting_door", (10, 10.6), (10, 11.5))
    level.door("day_room_door", (30.2, 28), (32.0, 28), "double_hinged")
    level.door("ward_a_b_door", (25.0, 21), (25.9, 21))
    charger = n("clinic_charger", 2.0, 3.0, is_charger="[4, true]")
    hall = n("waiting_hall", 5.0, 7.0)
    p(0, charger, (2.0, 7.0), hall, (9.0, 7.0), (11.0, CORRIDOR_Y))
    p(0, hall, (9.0, 11.05), n("reception", 7.5, 11.5))
    # The spine, down the middle of each leg: a point across from every door, the
    # corridor's two named places on it.
    first: dict[float, Point | int] = {20.0: n("main_corridor", 20.0, CORRIDOR_Y)}
    second: dict[float, Point | int] = {20.0: n("ward_corridor", WARD_X, 20.0)}
    rooms: dict[str, int] = {}
    for name, (x, y), (a, b) in SOUTH_ROOMS + NORTH_ROOMS:
        wall_y = 6.0 if y < CORRIDOR_Y else 8.2
        level.door(f"{name}_door", (a, wall_y), (b, wall_y))
        rooms[name] = n(name, x, y)
        if b < 30:  # the store's door is at the bend
            first.setdefault((a + b) / 2, ((a + b) / 2, CORRIDOR_Y))
            p(0, first[(a + b) / 2], rooms[name])
    for name, (x, y), (a, b) in WEST_ROOMS + EAST_ROOMS:
        wall_x = 30.0 if x < WARD_X else 32.2
        level.door(f"{name}_door", (wall_x, a), (wall_x, b))
        rooms[name] = n(name, x, y)
        second.setdefault((a + b) / 2, (WARD_X, (a + b) / 2))
        p(0, second[(a + b) / 2], rooms[name])
    bend = (WARD_X, CORRIDOR_Y)
    p(0, (11.0, CORRIDOR_Y), *(first[x] for x in sorted(first)), bend,
      *(second[y] for y in sorted(second)), (WARD_X, 27.0),
      n("day_room", 31.0, 31.0), n("day_room_tv", 26.5, 32.5))  # fmt: skip
    p(0, bend, (31.35, 4.5), rooms["store"])
    p(0, (9.0, 11.05), (11.0, 11.05), rooms["consulting_1"])  # from the hall, too
    return level


def rmf_clinic(folder: Path) -> Path:
    """The clinic's `.building.yaml` written into `folder` and imported beside it; the
    plan's path (its grid, `clinic.pgm`, next to it)."""
    source = folder / "clinic.building.yaml"
    source.write_text(one_level(clinic_level()))
    plan = folder / "clinic.yaml"
    console_ok("floorplan", "import", str(source), str(plan), "--level", "L1",
               "--name", "Clinic, ground floor", "--force")  # fmt: skip
    return plan
