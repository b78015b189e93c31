"""Open-RMF building maps written here as traffic-editor saves them, for the import tests.

An office building on two levels, drawn the way real maps are: walls meeting at the
vertices of the doors in them, floor polygons and a hole, three fleets (graph_idx 0, 1
and 2) whose lanes run side by side down the corridors and through the same doors, a
door just before the junction its lanes branch at, two vertices named `waiting_area`
(each fleet has its own), a door named `pantry` like the room behind it, corridors
with no named vertex at all, a charger close against a wall, doors in the outside walls,
and furniture (models) the importer does not read. Positions are pixels of the floor
drawing (`reference_image`, traffic-editor's default) measured at 0.02 m a pixel, or
metres (`cartesian_meters`); either way the map frame is the same, so the two import
alike. Without walls it is the same lanes and doors alone, as a map drawn for RMF's
traffic only is.

Level L1, 40 m by 22 m, in design metres (x right, y up; the map frame's y is this y
less 26), d a door:

    y=24 +--------+----------+-----------+----------+
         | dining |   gym    |  library  |  chapel  |
         |  room  d  +--d-+--+-----d-----+----d-----+ y=16
         |        |  |     back corridor (no names) d garden (outside)
    y=14 +---d----+  |  +--------d-------+----------+
         | lobby  |  |  | store | office_2 | server |
         | stairs |  +d-+---d---+----d-----+---d----+ y=9.2
         |        d J   main corridor       corridor_east
         |        +--d-----+---d----+----d-----+--d---+ y=6.8
 outside d        | office_1 | pantry | meeting | lab  |
     y=2 +--------+----------+--------+---------+------+
        x=2      12         18       24        32     42

The corridor door (x 12) leads from the lobby to a junction (J): the main corridor east,
and the north door (just beyond) to the north corridor, which turns east as the back
corridor; neither has a named vertex.

Level L2 is smaller: a corridor with rooms either side, named like some of L1's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

SCALE_M = 0.02  # metres a pixel of the drawing
HEIGHT_M = 26.0  # the drawing's height: map y is design y less this
Point = tuple[float, float]
Placing = Callable[[float, float], Point]  # a design point as the file writes it


@dataclass
class Level:
    """One level being drawn, in design metres (y up, from the drawing's bottom)."""

    vertices: list[tuple[float, float, str, dict[str, str]]] = field(default_factory=list)
    lanes: list[tuple[int, int, int]] = field(default_factory=list)  # a, b, graph
    walls: list[tuple[Point, Point]] = field(default_factory=list)
    doors: list[tuple[str, Point, Point, str]] = field(default_factory=list)  # name, ends, type
    floors: list[list[Point]] = field(default_factory=list)
    holes: list[list[Point]] = field(default_factory=list)
    models: list[tuple[str, Point]] = field(default_factory=list)
    _unnamed: dict[Point, int] = field(default_factory=dict)

    def vertex(self, point: Point | int) -> int:
        """The unnamed vertex at `point`, one for every use of it (walls meet at doors'
        vertices, lanes share their vertices); a vertex index is itself."""
        if isinstance(point, int):
            return point
        if point not in self._unnamed:
            self._unnamed[point] = len(self.vertices)
            self.vertices.append((point[0], point[1], "", {}))
        return self._unnamed[point]

    def named(self, name: str, x: float, y: float, **params: str) -> int:
        self.vertices.append((x, y, name, params))
        return len(self.vertices) - 1

    def path(self, graph: int, *points: Point | int) -> None:
        """Lanes of one fleet's graph from point to point."""
        ends = [self.vertex(point) for point in points]
        self.lanes += [(a, b, graph) for a, b in pairwise(ends)]

    def wall(self, *corners: Point) -> None:
        self.walls += list(pairwise(corners))

    def door(self, name: str, a: Point, b: Point, kind: str = "hinged") -> None:
        self.doors.append((name, a, b, kind))

    def yaml(self, system: str, walls: bool, place: Placing | None = None) -> str:
        """The level as traffic-editor writes it, under `levels:`; `place` writes a design
        point as the system does, when rmf_buildings does not know it (wgs84)."""
        position = place or (lambda x, y: _position(system, x, y))
        segments = _cut_at_doors(self.walls, [(a, b) for _, a, b, _ in self.doors]) if walls else []
        for a, b in segments:
            self.vertex(a), self.vertex(b)
        for _, a, b, _ in self.doors:
            self.vertex(a), self.vertex(b)
        corners = [(2.0, 2.0), (42.0, 2.0), (2.0, 24.0)]
        measured = [self.vertex(point) for point in corners]
        lines = ["    doors:"]
        for name, a, b, kind in self.doors:
            lines.append(f"      - [{self.vertex(a)}, {self.vertex(b)}, {{motion_axis: [1, start], "
                         "motion_degrees: [3, 90], motion_direction: [2, 1], "
                         f"name: [1, {name}], plugin: [1, normal], right_left_ratio: [3, 1], "
                         f"type: [1, {kind}]}}]")  # fmt: skip
        lines += ["    drawing:", "      filename: office.png", "    elevation: 0",
                  "    flattened_x_offset: 0", "    flattened_y_offset: 0"]  # fmt: skip
        for key, shapes in [("floors", self.floors if walls else []),
                            ("holes", self.holes if walls else [])]:  # fmt: skip
            lines.append(f"    {key}:" + ("" if shapes else " []"))
            for shape in shapes:
                ids = ", ".join(str(self.vertex(point)) for point in shape)
                lines += ["      - parameters: {ceiling_scale: [3, 1], indoor: [2, 0], "
                          "texture_name: [1, blue_linoleum], texture_scale: [3, 1]}",
                          f"        vertices: [{ids}]"]  # fmt: skip
        lines.append("    lanes:")
        for a, b, graph in self.lanes:
            lines.append(f"      - [{a}, {b}, {{bidirectional: [4, true], demo_mock_floor_name: "
                         f"[1, \"\"], demo_mock_lift_name: [1, \"\"], graph_idx: [2, {graph}], "
                         "orientation: [1, \"\"], speed_limit: [3, 0]}]")  # fmt: skip
        lines += ["    layers: {}", "    measurements:"]
        if system == "reference_image":
            for far, metres in [(measured[1], 40.0), (measured[2], 22.0)]:
                lines.append(f"      - [{measured[0]}, {far}, {{distance: [3, {metres}]}}]")
        lines.append("    models:")
        for model, (x, y) in self.models:
            px, py = position(x, y)
            lines.append(f"      - {{dispensable: false, model_name: {model}, name: {model}, "
                         f"static: true, x: {px}, y: {py}, yaw: 0, z: 0}}")  # fmt: skip
        lines.append("    vertices:")
        for x, y, name, params in self.vertices:
            px, py = position(x, y)
            extra = ", ".join(f"{key}: {value}" for key, value in params.items())
            shown = name if name else '""'
            lines.append(f"      - [{px}, {py}, 0, {shown}" + (f", {{{extra}}}]" if extra else "]"))
        lines.append("    walls:" + ("" if segments else " []"))
        for a, b in segments:
            lines.append(f"      - [{self.vertex(a)}, {self.vertex(b)}, {{alpha: [3, 1], "
                         "texture_height: [3, 2.5], texture_name: [1, default], "
                         "texture_scale: [3, 1], texture_width: [3, 1]}]")  # fmt: skip
        return "\n".join(lines) + "\n"


def _position(system: str, x: float, y: float) -> tuple[float, float]:
    """A design point as the file writes it: drawing pixels, row 0 at the top, or metres."""
    if system == "reference_image":
        return round(x / SCALE_M, 3), round((HEIGHT_M - y) / SCALE_M, 3)
    return round(x, 3), round(y - HEIGHT_M, 3)


def _cut_at_doors(walls: list[tuple[Point, Point]], doors: list[tuple[Point, Point]]
                  ) -> list[tuple[Point, Point]]:  # fmt: skip
    """Walls as traffic-editor users draw them: each wall ends at the vertices of the doors
    in it, so that the doorway is the door alone."""
    cut = []
    for a, b in walls:
        along = [0.0, 1.0]
        length2 = (b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2
        for end in (point for door in doors for point in door):
            cross = (b[0] - a[0]) * (end[1] - a[1]) - (b[1] - a[1]) * (end[0] - a[0])
            t = ((end[0] - a[0]) * (b[0] - a[0]) + (end[1] - a[1]) * (b[1] - a[1])) / length2
            if abs(cross) < 1e-9 and 0 < t < 1:
                along.append(t)
        along.sort()
        points = [(round(a[0] + t * (b[0] - a[0]), 3), round(a[1] + t * (b[1] - a[1]), 3))
                  for t in along]  # fmt: skip
        for p, q in pairwise(points):
            middle = ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2)
            if not any(_between(middle, *door) for door in doors):
                cut.append((p, q))
    return cut


def _between(point: Point, a: Point, b: Point) -> bool:
    cross = (b[0] - a[0]) * (point[1] - a[1]) - (b[1] - a[1]) * (point[0] - a[0])
    inside = min(a[0], b[0]) - 1e-9 <= point[0] <= max(a[0], b[0]) + 1e-9 and (
        min(a[1], b[1]) - 1e-9 <= point[1] <= max(a[1], b[1]) + 1e-9
    )
    return abs(cross) < 1e-9 and inside


def level_one() -> Level:
    level = Level()
    # Walls: the outside, the lobby's and the corridors', and between the rooms.
    level.wall((2, 2), (42, 2), (42, 24), (2, 24), (2, 2))
    level.wall((12, 2), (12, 6.8))
    level.wall((12, 6.8), (42, 6.8))  # the main corridor's south wall
    level.wall((12, 9.2), (42, 9.2))  # its north wall
    level.wall((12, 6.8), (12, 9.2))  # the corridor door's wall
    level.wall((12, 9.2), (12, 24))  # the lobby's and dining room's east wall
    level.wall((2, 14), (12, 14))  # between the lobby and the dining room
    level.wall((15, 9.2), (15, 14))  # the north corridor's east wall
    level.wall((15, 14), (42, 14))  # the back corridor's south wall
    level.wall((15, 16), (42, 16))  # its north wall
    level.wall((13, 16), (15, 16))  # the north corridor's end, with a door to the gym
    for x in (18, 24, 32):
        level.wall((x, 2), (x, 6.8))
    for x in (22, 30):
        level.wall((x, 9.2), (x, 14))
    for x in (24, 33):
        level.wall((x, 16), (x, 24))
    level.wall((12, 16), (13, 16))
    # Doors: outside, into the corridor, and off it into every room.
    level.door("main_entrance", (2, 3.0), (2, 4.6), "double_sliding")
    level.door("garden_door", (42, 14.5), (42, 15.5))
    level.door("corridor_door", (12, 7.0), (12, 9.0), "double_sliding")
    level.door("office_1_door", (14.5, 6.8), (15.5, 6.8))
    level.door("pantry", (20.4, 6.8), (21.6, 6.8))  # named as the room is
    level.door("meeting_door", (25.4, 6.8), (26.6, 6.8))
    level.door("lab_door", (33.0, 6.8), (34.2, 6.8))
    level.door("north_door", (12.1, 9.2), (14.9, 9.2), "double_hinged")
    level.door("store_door", (18.0, 9.2), (19.2, 9.2))
    level.door("office_2_door", (24.0, 9.2), (25.2, 9.2))
    level.door("office_2_back_door", (27.0, 14), (28.2, 14))
    level.door("server_door", (33.0, 9.2), (34.2, 9.2))
    level.door("gym_door", (13.4, 16), (14.6, 16))
    level.door("library_door", (25.0, 16), (26.2, 16))
    level.door("chapel_door", (36.0, 16), (37.2, 16))
    level.door("dining_door", (6.4, 14), (7.6, 14), "double_hinged")
    level.door("dining_side_door", (12, 17.0), (12, 18.2))
    # The north corridor meets the main corridor at a wide opening: its door is x 12.1-14.9.
    level.floors.append([(2, 2), (42, 2), (42, 24), (2, 24)])
    level.holes.append([(9.5, 11), (11.5, 11), (11.5, 13), (9.5, 13)])  # the stairwell
    level.models += [("OfficeChairBlack", (16.5, 4.5)), ("Table", (28, 3.5))]

    n = level.named
    # Close against the lobby's west wall (0.35 m from its middle): moved clear of it.
    charger = n("tinyRobot1_charger", 2.35, 7.0, is_charger="[4, true]",
                is_parking_spot="[4, true]")  # fmt: skip
    delivery_charger = n("deliveryRobot1_charger", 3.2, 10.0, is_charger="[4, true]")
    cleaner_charger = n("cleanerBot_charger", 3.2, 5.5, is_charger="[4, true]")
    reception = n("reception", 4.5, 12.0)
    lobby = n("lobby", 7.0, 8.0)
    entrance = n("entrance", 3.8, 3.8)
    waiting = n("waiting_area", 9.5, 4.0)  # fleet 1's
    waiting_2 = n("waiting_area", 9.5, 5.4)  # fleet 2's, by the same name
    corridor_east = n("corridor_east", 40.5, 8.0)
    office_1 = n("office_1", 15.0, 4.0)
    pantry = n("pantry", 21.0, 4.5, pickup_dispenser="[1, coke_dispenser]")
    coffee = n("coffee_machine", 19.3, 3.0)
    meeting = n("meeting_room", 28.0, 4.5)
    projector = n("projector", 30.8, 3.2)
    lab = n("lab", 36.5, 4.5)
    bench = n("lab_bench", 40.5, 3.2)
    store = n("store_room", 19.0, 12.0)
    office_2 = n("office_2", 26.0, 11.5)
    server = n("server_room", 36.0, 11.5)
    gym = n("gym", 19.5, 20.0)
    library = n("library", 28.5, 20.0)
    reading = n("reading_corner", 31.5, 22.5)
    chapel = n("chapel", 37.5, 20.0)
    dining = n("dining_room", 7.5, 18.0)
    table_1 = n("dining_table_1", 4.5, 21.5)
    table_2 = n("dining_table_2", 10.0, 21.5)
    nurse = n("nurse_station", 4.5, 17.0)

    p = level.path
    # Fleet 0 (tinyRobot): the lobby, through the corridor door to a junction just past
    # it, east down the middle of the corridor and into each room.
    p(0, charger, (3.5, 7.0), lobby, (11.0, 8.0), (13.0, 8.0), (15.0, 8.0), (21.0, 8.0),
      (26.0, 8.0), (33.6, 8.0), corridor_east)  # fmt: skip
    p(0, (3.5, 7.0), entrance)
    p(0, lobby, reception)
    p(0, lobby, waiting)
    # From the junction, the north and back corridors, where no vertex has a name.
    p(0, (13.0, 8.0), (13.5, 10.5), (14.0, 15.0), (22.0, 15.0), (25.6, 15.0), (27.6, 15.0),
      (36.6, 15.0), (40.0, 15.0))  # fmt: skip
    p(0, (15.0, 8.0), office_1)
    p(0, (21.0, 8.0), (21.0, 5.8), pantry)
    p(0, (26.0, 8.0), (26.0, 5.8), meeting, projector)
    p(0, (33.6, 8.0), (33.6, 5.8), lab, bench)
    p(0, (15.0, 8.0), (18.6, 8.4), (18.6, 10.5), store)
    p(0, (26.0, 8.0), (24.6, 8.4), (24.6, 10.5), office_2, (27.6, 13.0), (27.6, 15.0))
    p(0, (33.6, 8.0), (33.6, 10.5), server)
    p(0, (14.0, 15.0), (14.0, 17.5), gym)
    p(0, (25.6, 15.0), (25.6, 17.5), library, reading)
    p(0, (36.6, 15.0), (36.6, 17.5), chapel)
    p(0, lobby, (7.0, 13.0), (7.0, 15.0), dining, table_1)
    p(0, dining, table_2)
    p(0, dining, nurse)
    p(0, dining, (11.0, 17.6), (13.0, 17.6), (14.0, 17.5))  # the side door: a loop
    # Fleet 1 (deliveryRobot): its own lanes, 0.4 m north of the middle, through the same
    # corridor door, and side by side with fleet 0's through the pantry and meeting room
    # and lab doors.
    p(1, delivery_charger, (5.0, 10.0), (8.0, 8.4), (11.0, 8.4), (13.0, 8.4), (20.8, 8.4),
      (25.8, 8.4), (33.3, 8.4), (39.0, 8.4))  # fmt: skip
    p(1, (8.0, 8.4), waiting)
    p(1, (20.8, 8.4), (20.8, 5.8), coffee)
    p(1, (25.8, 8.4), (25.8, 5.8), projector)
    p(1, (33.3, 8.4), (33.3, 5.8), bench)
    # Fleet 2 (cleanerBot): 0.4 m south of the middle, its own waiting area.
    p(2, cleaner_charger, (5.0, 6.0), waiting_2, (11.0, 7.6), (13.0, 7.6), (14.8, 7.6),
      (21.2, 7.6), (33.9, 7.6), (39.0, 7.6))  # fmt: skip
    p(2, (14.8, 7.6), (14.8, 5.8), office_1)
    p(2, (21.2, 7.6), (21.2, 5.8), pantry)
    p(2, (33.9, 7.6), (33.9, 5.8), lab)
    return level


def level_two() -> Level:
    level = Level()
    level.wall((2, 2), (42, 2), (42, 24), (2, 24), (2, 2))
    level.wall((2, 10), (42, 10))
    level.wall((2, 12.4), (42, 12.4))
    for x in (12, 22, 32):
        level.wall((x, 2), (x, 10))
        level.wall((x, 12.4), (x, 24))
    doors = {"ward_a": (7, 10), "ward_b": (17, 10), "ward_c": (27, 10), "ward_d": (37, 10),
             "day_room": (7, 12.4), "therapy": (17, 12.4), "office_3": (27, 12.4),
             "linen": (37, 12.4)}  # fmt: skip
    level.floors.append([(2, 2), (42, 2), (42, 24), (2, 24)])
    p = level.path
    p(0, (4.0, 11.2), *((x, 11.2) for x in (7, 17, 27, 37)), (40.0, 11.2))
    for name, (x, y) in doors.items():
        level.door(f"{name}_door", (x - 0.6, y), (x + 0.6, y))
        inside = y - 4 if y < 11 else y + 4
        room = level.named(name, x, inside)
        p(0, (x, 11.2), room)
    return level


def building(system: str = "reference_image", walls: bool = True,
             levels: tuple[str, ...] = ("L1", "L2")) -> str:  # fmt: skip
    """The office building as a `.building.yaml`'s text."""
    drawn = {"L1": level_one, "L2": level_two}
    text = [f"coordinate_system: {system}", "crowd_sim:", "  enable: 0", "graphs: {}", "levels:"]
    for name in levels:
        text += [f"  {name}:", drawn[name]().yaml(system, walls)]
    text += ["lifts: {}", "name: office_building", ""]
    return "\n".join(text)


def write_building(folder: Path, name: str = "office", **options: object) -> Path:
    path = folder / f"{name}.building.yaml"
    path.write_text(building(**options))  # type: ignore[arg-type]
    return path


def one_level(level: Level) -> str:
    """A building of one level, L1, in metres (the shapes below)."""
    text = ["coordinate_system: cartesian_meters", "levels:", "  L1:",
            level.yaml("cartesian_meters", walls=True), "name: shapes", ""]  # fmt: skip
    return "\n".join(text)


def gap_only(gap: float) -> Level:
    """Two rooms, 10 m by 8 m each, and the wall between them stopping `gap` metres short
    of the north wall: no door, only the gap."""
    level = Level()
    level.wall((2, 2), (22, 2), (22, 10), (2, 10), (2, 2))
    level.wall((12, 2), (12, 10 - gap))
    level.floors.append([(2, 2), (22, 2), (22, 10), (2, 10)])
    level.named("west_room", 7, 6)
    level.named("east_room", 17, 6)
    return level


def stray_vertex() -> Level:
    """Level L2, and a named vertex 1.5 km off the drawing (a marker left from an old map)."""
    level = level_two()
    level.named("old_marker", 1500.0, -1500.0)
    return level


def junction_by_door(past: float) -> Level:
    """Lanes only: from the hall south through a door at y 10, to a junction `past` metres
    beyond the door's line (less than 0: before it) that branches to two beds."""
    level = Level()
    hall, chair = level.named("hall", 5, 14), level.named("hall_chair", 8, 14)
    level.path(0, hall, chair)
    junction = (5.0, 10.0 - past)
    level.path(0, hall, junction, level.named("bed_1", 3, 6))
    level.path(0, junction, level.named("bed_2", 7, 6))
    level.door("bedroom_door", (4.4, 10.0), (5.6, 10.0))
    return level


def open_hall(places: int, width: float = 60.0, depth: float = 40.0) -> Level:
    """One open hall (an airport's airside), `places` named places in rows, no inner walls."""
    level = Level()
    level.wall((0, 0), (width, 0), (width, depth), (0, depth), (0, 0))
    level.floors.append([(0, 0), (width, 0), (width, depth), (0, depth)])
    columns = 20
    rows = -(-places // columns)
    for k in range(places):
        row, column = divmod(k, columns)
        x = 2 + column * (width - 4) / (columns - 1)
        y = 2 + row * (depth - 4) / max(1, rows - 1)
        level.named(f"kiosk_{k}", round(x, 3), round(y, 3))
    return level
