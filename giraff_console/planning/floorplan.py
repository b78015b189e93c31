"""Floor plans: the building as named rooms and the doorways between them (thesis §2.6.2).

The thesis proposes giving the robot "a floor plan of the building ... naming each room
and the available doorways between them", stored as a graph that A* searches to find
which doors to go through (room_graph.py). An optional occupancy grid (§2.6.4) lies under
it for planning between the doors, and optional landmarks, printed markers on the walls
that the robot finds itself by (§2.3, checked in landmarks.py). Floor plans are written
by hand, so every mistake is reported as `file:line: message` naming the key, all of
them at once, and never as a traceback; floorplans/README.md documents the schema and
the rules checked here.
"""

from __future__ import annotations

import math
import re
import reprlib
import shlex
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from giraff_console.file_limits import CountLimit, read_bounded, too_many
from giraff_console.planning.names import no_such
from giraff_console.yaml_source import YamlSourceError, parse_yaml

Point = tuple[float, float]

DOOR_WIDTH_M = 0.9
# How far a door's centre may lie from a wall of each of its rooms' outlines: outlines
# drawn on either face of a thin wall still share the door.
DOOR_TOLERANCE_M = 0.1
# No building is larger: the grid drawn from outlines (rasterise.py) must fit in memory.
MAX_EXTENT_M = 1000.0

# Values quoted in messages are cut short: a file may hold a megabyte on one key, or
# lists nested hundreds deep, which a plain repr would print whole or not at all.
_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxstring, _SHORT.maxother, _SHORT.maxlong = 3, 60, 60, 40
_ID = re.compile(r"[A-Za-z0-9_-]{1,64}\Z")  # ids are typed in commands: "go room-101"
_TOP = {"name": True, "rooms": True, "doors": True, "grid": False, "start": False}
_TOP |= {"landmarks": False}
_ROOM = {"label": False, "at": True, "heading": False, "outline": False}
_DOOR = {"between": True, "at": True, "width": False, "open": False, "id": False}
_GRID = {"image": True, "resolution": True, "origin": False, "negate": False}
_GRID |= {"occupied_thresh": False, "free_thresh": False}
_LANDMARKS = {"family": True, "size": True, "markers": True}
_MARKER = {"id": True, "at": True, "height": True, "facing": True, "sigma": False}
# A marker's uncertainty, as a survey writes it: metres and degrees, standard deviations.
MARKER_SIGMA_M = (0.0, 10.0)
MARKER_SIGMA_DEG = (0.0, 180.0)
# A marker's printed side and the height of its centre, metres. Below 5 cm the robot's
# camera resolves a marker only from a metre or so; above 30 cm it no longer fits on a
# page to print. Its centre at 0.3 to 2.2 m keeps the whole of it between the skirting
# board and a 2.5 m ceiling, where the camera in the robot's head (1.3 m) can see it.
MARKER_SIZE_M = (0.05, 0.30)
MARKER_HEIGHT_M = (0.3, 2.2)


@dataclass(frozen=True)
class Room:
    id: str
    label: str
    at: Point  # where "go <id>" ends, metres in the map frame
    heading: float | None  # arrival heading, degrees counter-clockwise from +x
    outline: tuple[Point, ...] | None  # a polygon whose edges are walls


@dataclass(frozen=True)
class Door:
    id: str
    between: tuple[str, str]
    at: Point  # the centre of the doorway
    width: float
    open: bool


@dataclass(frozen=True)
class GridSpec:
    """Where the occupancy grid is and how to read it, as a ROS map_server YAML says."""

    image: Path
    resolution: float  # metres per pixel
    origin: tuple[float, float, float]  # x, y, yaw of the lower-left pixel's corner
    negate: int
    occupied_thresh: float
    free_thresh: float


@dataclass(frozen=True)
class Marker:
    """A fiducial marker fixed flat to a wall (issue 14), for the robot to find itself
    by: the camera sees it and knows its id, the plan says where it is."""

    id: int
    at: Point  # its centre on the wall, metres in the map frame
    height: float  # its centre above the floor, metres
    facing: float  # the way its face looks (its normal), degrees counter-clockwise from +x
    # How well `at` (metres, along the worst direction) and `facing` (degrees) are known,
    # as a survey found them (missions/survey.py); None: put up with a tape measure.
    sigma: tuple[float, float] | None = None


@dataclass(frozen=True)
class Landmarks:
    family: str  # a cv2.aruco predefined dictionary, lower case, no DICT_: apriltag_36h11
    size: float  # the printed side of the black square, metres
    markers: tuple[Marker, ...]


@dataclass(frozen=True)
class FloorPlan:
    name: str
    rooms: dict[str, Room]
    doors: list[Door]
    grid: GridSpec | None
    start: str | None
    path: Path
    # Last, with a default, so that every FloorPlan(...) written before it still works.
    landmarks: Landmarks | None = None

    def no_room(self, name: str, also: Collection[str] = ()) -> str:
        """What to say of a room `name` it does not have: the likest of its rooms (and of
        `also`, such as the dock), or where to see them all (planning/names.py)."""
        shown = shlex.quote(str(self.path.resolve()))
        return no_such("room", name, sorted({*self.rooms, *also}),
                       f"`giraff-console floorplan show {shown}` draws them")  # fmt: skip


@dataclass(frozen=True)
class Problem:
    """One mistake in a floor plan file; prints as `path:line: message`."""

    path: Path
    line: int | None
    message: str

    def __str__(self) -> str:
        where = f"{self.path}:{self.line}" if self.line else str(self.path)
        return f"{where}: {self.message}"


class FloorPlanError(Exception):
    """A floor plan that cannot be used, with every problem found in it."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = problems
        super().__init__("\n".join(map(str, problems)))


def shown(value: object) -> str:
    """A value as a message quotes it: short, whatever its size or depth."""
    return _SHORT.repr(value)


def is_id(value: object) -> bool:
    """Whether `value` can be a room's or a door's id."""
    return isinstance(value, str) and _ID.match(value) is not None


def _finite(value: int | float) -> bool:
    """True for a number a float can hold: `10**400` is an int YAML reads, too big."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def load_floorplan(path: str | Path) -> FloorPlan:
    """The floor plan in `path`; raises FloorPlanError listing its problems."""
    plan, problems = _read(Path(path))
    if problems or plan is None:
        raise FloorPlanError(problems)
    return plan


def check_floorplan(path: str | Path) -> list[Problem]:
    """Every problem in the floor plan file at `path`; empty if it can be used."""
    return _read(Path(path))[1]


Where = tuple[str | int, ...]


def dotted(where: Where) -> str:
    """A place in a YAML file as a person reads it: `rooms.kitchen.at`, `doors[2]`."""
    text = ""
    for part in where:
        text += f"[{part}]" if isinstance(part, int) else f".{part}" if text else part
    return text or "the file"


def _node_lines(node: yaml.Node, where: Where, lines: dict, duplicates: list) -> None:
    """Record the line of every key and list item under `node`, and duplicate keys,
    which PyYAML's loader would silently drop (it keeps the last)."""
    if isinstance(node, yaml.MappingNode):
        seen = set()
        for key, value in node.value:
            # A complex key (`? [a, b]`) is named by its tag: its repr may be huge or deep.
            name = key.value if isinstance(key, yaml.ScalarNode) else f"<{key.tag}>"
            if name in seen:
                duplicates.append((where, name, key.start_mark.line + 1))
            seen.add(name)
            lines.setdefault((*where, name), key.start_mark.line + 1)
            _node_lines(value, (*where, name), lines, duplicates)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            lines[(*where, i)] = item.start_mark.line + 1
            _node_lines(item, (*where, i), lines, duplicates)


class ProblemLog:
    """Problems found in a YAML file, each at the line of the key or item it is about
    (or of the nearest one above it that has a line)."""

    def __init__(self, path: Path, lines: dict[Where, int]) -> None:
        self.path, self.lines = path, lines
        self.problems: list[Problem] = []

    def add(self, where: Where, message: str) -> None:
        while where and where not in self.lines:
            where = where[:-1]
        self.problems.append(Problem(self.path, self.lines.get(where), message))


class _Reader(ProblemLog):
    """Turns the loaded YAML into a FloorPlan, collecting problems rather than stopping."""

    def bad(self, where: Where, what: str, value: Any) -> None:
        self.add(where, f"{dotted(where)} should be {what}, not {shown(value)}")

    def mapping(self, value: Any, where: Where, keys: dict[str, bool]) -> dict | None:
        if not isinstance(value, dict):
            self.bad(where, "a mapping of keys", value)
            return None
        for key in value:
            if key not in keys:
                sub = (*where, str(key))
                self.add(sub, f"unknown key {dotted(sub)} (expected {', '.join(keys)})")
        for key, required in keys.items():
            if required and key not in value:
                self.add(where, f"missing key {dotted((*where, key))}")
        return value

    def number(self, value: Any, where: Where, low: float = -math.inf, high=math.inf) -> Any:
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.bad(where, "a number", value)
        elif not _finite(value):
            self.bad(where, "a finite number", value)
        elif not low <= value <= high:
            self.add(where, f"{dotted(where)} is {value}, out of range [{low}, {high}]")
        else:
            return float(value)
        return None

    def numbers(self, value: Any, where: Where, count: int, what: str) -> Any:
        good = isinstance(value, list) and len(value) == count
        if good and all(self.number(v, (*where, i)) is not None for i, v in enumerate(value)):
            return tuple(float(v) for v in value)
        if not good:
            self.bad(where, what, value)
        return None

    def point(self, value: Any, where: Where) -> Any:
        point = self.numbers(value, where, 2, "a pair of numbers [x, y] in metres")
        if point is not None and max(map(abs, point)) > MAX_EXTENT_M:
            self.add(where, f"{dotted(where)} is more than {MAX_EXTENT_M:g} m from the origin")
            return None
        return point

    def text(self, value: Any, where: Where, as_id: bool = False) -> Any:
        if as_id and not is_id(value):
            self.bad(where, "an id of letters, digits, '-' and '_' (up to 64)", value)
        elif not isinstance(value, str):
            self.bad(where, "text", value)
        else:
            return value
        return None

    def room(self, room_id: str, value: Any) -> Room | None:
        where: Where = ("rooms", room_id)
        raw = self.mapping(value, where, _ROOM)
        if raw is None or "at" not in raw:
            return None
        before = len(self.problems)
        label = self.text(raw.get("label", room_id), (*where, "label"))
        at = self.point(raw["at"], (*where, "at"))
        heading = raw.get("heading")
        if heading is not None:
            heading = self.number(heading, (*where, "heading"))
        outline = raw.get("outline")
        if outline is not None:
            if isinstance(outline, list) and len(outline) >= 3:
                corners = [self.point(p, (*where, "outline", i)) for i, p in enumerate(outline)]
                outline = tuple(corners)
            else:
                self.bad((*where, "outline"), "a list of at least 3 points [x, y]", outline)
        if len(self.problems) > before:
            return None
        return Room(room_id, label, at, heading, outline)

    def door(self, i: int, value: Any, room_ids: set[str]) -> Door | None:
        where: Where = ("doors", i)
        raw = self.mapping(value, where, _DOOR)
        if raw is None or "at" not in raw or "between" not in raw:
            return None
        before = len(self.problems)
        between = raw["between"]
        pair = isinstance(between, list) and len(between) == 2
        if not pair or not all(isinstance(side, str) for side in between):
            self.bad((*where, "between"), "two room ids [a, b]", between)
        elif between[0] == between[1]:
            self.add((*where, "between"), f"door {i} leads from {between[0]!r} to itself")
        else:
            for side in between:
                if side not in room_ids:
                    self.add((*where, "between"), f"door {i} leads to an unknown room {side!r}")
        at = self.point(raw["at"], (*where, "at"))
        width = self.number(raw.get("width", DOOR_WIDTH_M), (*where, "width"), 0.01, 100.0)
        is_open = raw.get("open", True)
        if not isinstance(is_open, bool):
            self.bad((*where, "open"), "true or false", is_open)
        if len(self.problems) > before:
            return None
        door_id = f"{between[0]}-{between[1]}"
        if "id" in raw and self.text(raw["id"], (*where, "id"), as_id=True) is None:
            return None
        return Door(raw.get("id", door_id), (between[0], between[1]), at, width, is_open)

    def grid(self, value: Any) -> GridSpec | None:
        raw = self.mapping(value, ("grid",), _GRID)
        if raw is None or "image" not in raw or "resolution" not in raw:
            return None
        before = len(self.problems)
        image = self.text(raw["image"], ("grid", "image"))
        resolution = self.number(raw["resolution"], ("grid", "resolution"), 1e-6)
        origin = self.numbers(
            raw.get("origin", [0, 0, 0]), ("grid", "origin"), 3, "three numbers [x, y, yaw]"
        )
        negate = raw.get("negate", 0)
        if negate not in (0, 1) or isinstance(negate, float):
            self.bad(("grid", "negate"), "0 or 1", negate)
        occupied = self.number(raw.get("occupied_thresh", 0.65), ("grid", "occupied_thresh"), 0, 1)
        free = self.number(raw.get("free_thresh", 0.196), ("grid", "free_thresh"), 0, 1)
        if occupied is not None and free is not None and free > occupied:
            self.add(("grid", "free_thresh"), "grid.free_thresh is above grid.occupied_thresh")
        if len(self.problems) > before:
            return None
        return GridSpec(self.path.parent / image, resolution, origin, int(negate), occupied, free)

    def landmarks(self, value: Any) -> tuple[Any, Any, list[tuple[int, Marker]]]:
        """The family, the size and the markers that read well, each with its index in
        the file's list; None for a family or size that does not."""
        where: Where = ("landmarks",)
        raw = self.mapping(value, where, _LANDMARKS) or {}
        family = self.text(raw["family"], (*where, "family")) if "family" in raw else None
        size = self.number(raw["size"], (*where, "size"), *MARKER_SIZE_M) if "size" in raw else None
        raw_markers = raw.get("markers") or []  # "markers:" with nothing after it: none yet
        if not isinstance(raw_markers, list):
            self.bad((*where, "markers"), "a list of markers", raw_markers)
            raw_markers = []
        markers = [(i, self.marker(i, item)) for i, item in enumerate(raw_markers)]
        return family, size, [(i, marker) for i, marker in markers if marker is not None]

    def marker(self, i: int, value: Any) -> Marker | None:
        where: Where = ("landmarks", "markers", i)
        raw = self.mapping(value, where, _MARKER)
        if raw is None or any(required and key not in raw for key, required in _MARKER.items()):
            return None
        before = len(self.problems)
        marker_id = raw["id"]
        if isinstance(marker_id, bool) or not isinstance(marker_id, int) or marker_id < 0:
            self.bad((*where, "id"), "a whole number from 0", marker_id)
        at = self.point(raw["at"], (*where, "at"))
        height = self.number(raw["height"], (*where, "height"), *MARKER_HEIGHT_M)
        facing = self.number(raw["facing"], (*where, "facing"), -360.0, 360.0)
        sigma = None
        if "sigma" in raw:
            sigma = self.numbers(
                raw["sigma"],
                (*where, "sigma"),
                2,
                "[metres, degrees]: how well `at` and `facing` are known",
            )
            (low_m, high_m), (low_deg, high_deg) = MARKER_SIGMA_M, MARKER_SIGMA_DEG
            if sigma is not None and not (low_m < sigma[0] <= high_m
                                          and low_deg < sigma[1] <= high_deg):  # fmt: skip
                self.add((*where, "sigma"), f"{dotted((*where, 'sigma'))} is {list(sigma)}: "
                         f"metres in ({low_m:g}, {high_m:g}] and degrees in "
                         f"({low_deg:g}, {high_deg:g}]")  # fmt: skip
        if len(self.problems) > before:
            return None
        return Marker(marker_id, at, height, facing % 360.0, sigma)


def load_yaml(path: Path) -> tuple[yaml.Node | None, Any]:
    """The YAML file at `path`, as its node tree (for lines) and its document; raises
    FloorPlanError, at the line where one is known, for whatever the bytes are."""
    try:
        data = read_bounded(path)
    except OSError as error:
        raise FloorPlanError([Problem(path, None, f"cannot read it: {error}")]) from None
    try:
        return parse_yaml(data)
    except YamlSourceError as error:
        raise FloorPlanError([Problem(path, error.line, error.message)]) from None


def _read(path: Path) -> tuple[FloorPlan | None, list[Problem]]:
    try:
        node, document = load_yaml(path)
    except FloorPlanError as error:
        return None, error.problems
    lines: dict[Where, int] = {}
    duplicates: list[tuple[Where, str, int]] = []
    if node is not None:
        _node_lines(node, (), lines, duplicates)
    reader = _Reader(path, lines)
    for where, key, line in duplicates:
        reader.problems.append(Problem(path, line, f"duplicate key {dotted((*where, key))}"))
    top = reader.mapping(document, (), _TOP)
    if top is None or _too_many(reader, top):
        return None, reader.problems
    name = reader.text(top.get("name", ""), ("name",))
    raw_rooms = top.get("rooms", {})
    if "rooms" in top and (not isinstance(raw_rooms, dict) or not raw_rooms):
        reader.bad(("rooms",), "a mapping of room ids to rooms", raw_rooms)
        raw_rooms = {}
    rooms = {}
    for room_id, value in raw_rooms.items():
        if reader.text(room_id, ("rooms", str(room_id)), as_id=True) is not None:
            room = reader.room(room_id, value)
            if room is not None:
                rooms[room_id] = room
    raw_doors = top.get("doors", [])
    if raw_doors is None:
        raw_doors = []  # "doors:" with nothing after it: a building of one room
    if not isinstance(raw_doors, list):
        reader.bad(("doors",), "a list of doors", raw_doors)
        raw_doors = []
    doors = [reader.door(i, value, set(raw_rooms)) for i, value in enumerate(raw_doors)]
    grid = reader.grid(top["grid"]) if top.get("grid") is not None else None
    start = top.get("start")
    if start is not None and (not isinstance(start, str) or start not in raw_rooms):
        reader.add(("start",), f"start names an unknown room {shown(start)}")
        start = None
    _check_ids(reader, doors, set(raw_rooms))
    for i, door in enumerate(doors):
        if door:
            _check_door_on_walls(reader, i, door, rooms)
    good_doors = [door for door in doors if door]
    if not reader.problems:  # a broken door would make rooms look unreachable
        _check_reachable(reader, list(rooms), good_doors, start)
    if grid is not None:
        _check_grid(reader, grid, rooms, doors)
    # Markers are checked against the walls once those read well: every room, and the
    # grid too when the walls are its (a plan without outlines).
    walled = any(room.outline for room in rooms.values()) or top.get("grid") is None
    whole = len(rooms) == len(raw_rooms) and (walled or grid is not None)
    landmarks = None
    if top.get("landmarks") is not None:
        walls = FloorPlan(name, rooms, good_doors, grid, None, path) if whole else None
        landmarks = _landmarks(reader, top["landmarks"], walls)
    if reader.problems:
        return None, reader.problems
    return FloorPlan(name, rooms, good_doors, grid, start, path, landmarks), []


def _too_many(reader: _Reader, top: dict[Any, Any]) -> bool:
    """Whether the plan holds more rooms, doors or markers than the limits
    (file_limits.py), each then a problem: refused before any of them is checked, since
    the checks (doors on walls, markers in sight) grow faster than the count."""
    landmarks = top.get("landmarks")
    markers = landmarks.get("markers") if isinstance(landmarks, dict) else None
    before = len(reader.problems)
    counted: tuple[tuple[Where, Any, CountLimit], ...] = (
        (("rooms",), top.get("rooms"), "rooms"),
        (("doors",), top.get("doors"), "doors"),
        (("landmarks", "markers"), markers, "markers"),
    )
    for where, items, limit in counted:
        message = too_many(len(items), limit, limit) if isinstance(items, list | dict) else None
        if message is not None:
            reader.add(where, f"{dotted(where)}: {message}")
    return len(reader.problems) > before


def _landmarks(reader: _Reader, value: Any, walls: FloorPlan | None) -> Landmarks | None:
    """The plan's markers, checked against the walls of `walls` (its rooms, doors and
    grid), None when those did not all read well (a broken room, or a broken grid key,
    would leave its markers off every wall)."""
    # Imported here: the checks need the plan's walls, and walls.py imports this module.
    from giraff_console.planning.landmark_checks import landmark_problems

    family, size, markers = reader.landmarks(value)
    for where, message in landmark_problems(family, size, markers, walls):
        reader.add(where, message)
    if family is None or size is None:
        return None
    return Landmarks(family, size, tuple(marker for _, marker in markers))


def _check_ids(reader: _Reader, doors: list[Door | None], room_ids: set[str]) -> None:
    seen: set[str] = set()
    for i, door in enumerate(doors):
        if door is None:
            continue
        if door.id in room_ids:
            reader.add(("doors", i), f"door id {door.id!r} is also a room id")
        elif door.id in seen:
            reader.add(("doors", i), f"duplicate door id {door.id!r}: give one of them another id")
        seen.add(door.id)


def _distance_to_outline(point: Point, outline: tuple[Point, ...]) -> float:
    px, py = point
    best = math.inf
    for (ax, ay), (bx, by) in zip(outline, outline[1:] + outline[:1], strict=True):
        dx, dy = bx - ax, by - ay
        span = dx * dx + dy * dy
        t = 0.0 if span == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / span))
        best = min(best, math.hypot(px - ax - t * dx, py - ay - t * dy))
    return best


def _check_door_on_walls(reader: _Reader, i: int, door: Door, rooms: dict[str, Room]) -> None:
    """A door is a gap in a wall the two rooms share: it must lie on both outlines."""
    sides = [rooms.get(room_id) for room_id in door.between]
    if any(room is None or room.outline is None for room in sides):
        return
    for room in sides:
        assert room is not None and room.outline is not None
        gap = _distance_to_outline(door.at, room.outline)
        if gap > DOOR_TOLERANCE_M:
            reader.add(
                ("doors", i, "at"),
                f"door {door.id!r} at {list(door.at)} is {gap:.2f} m "
                f"from the walls of {room.id!r} (at most {DOOR_TOLERANCE_M} m)",
            )


def _check_reachable(reader: _Reader, rooms: list[str], doors: list[Door], start: Any) -> None:
    """Every room must be reachable through some door, open or closed: doors are part of
    the building, closing one is something that happens while the robot runs."""
    if not rooms:
        return
    # A walk through the doors, either way, from the root. Not networkx, whose import
    # alone cost every console a tenth of a second at its start (issue 26, item 6).
    joined: dict[str, set[str]] = {room_id: set() for room_id in rooms}
    for a, b in (door.between for door in doors):
        joined.setdefault(a, set()).add(b)
        joined.setdefault(b, set()).add(a)
    root = start if start is not None else rooms[0]
    reached, waiting = {root}, [root]
    while waiting:
        for room_id in joined[waiting.pop()] - reached:
            reached.add(room_id)
            waiting.append(room_id)
    for room_id in rooms:
        if room_id not in reached:
            reader.add(
                ("rooms", room_id),
                f"room {room_id!r} cannot be reached from {root!r}: no chain of doors leads to it",
            )


def _check_grid(
    reader: _Reader, grid: GridSpec, rooms: dict[str, Room], doors: list[Door | None]
) -> None:
    """The grid image must load and fill the size its header says, every room's `at`
    must be a free cell of it, and no door's `at` an occupied one (the robot could never
    pass it, open or not). Read by ROS map_server's rules: row 0 is the top, `origin`
    the lower-left pixel's corner."""
    # Imported here: ros_map.py imports this module. The checks read_grid_image makes,
    # reported here at the grid key's line.
    from giraff_console.planning.ros_map import grid_image_problem

    if not grid.image.exists():
        reader.add(("grid", "image"), f"grid image {str(grid.image)!r} is missing")
        return
    try:
        data = read_bounded(grid.image, "image_bytes")
    except OSError as error:
        reader.add(("grid", "image"), f"grid image {str(grid.image)!r}: cannot read it: "
                   f"{error.strerror or error}")  # fmt: skip
        return
    mismatch = grid_image_problem(data)
    if mismatch is not None:
        reader.add(("grid", "image"), f"grid image {str(grid.image)!r}: {mismatch}")
        return
    pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        reader.add(("grid", "image"), f"grid image {str(grid.image)!r} is unreadable")
        return
    scale = float(np.iinfo(pixels.dtype.name).max) if pixels.dtype.kind in "ui" else 255.0
    rows, cols = pixels.shape[:2]

    def occupied(found: tuple[int, int]) -> bool:
        # Read at the cell alone: the whole grid as floats would be 8 bytes a cell.
        pixel = pixels[found]
        if pixels.ndim == 3:  # colour: the mean of the colour channels, alpha ignored
            pixel = pixel[: 3 if pixels.shape[2] >= 3 else 1].mean()
        value = float(pixel) / scale
        return (value if grid.negate else 1.0 - value) > grid.occupied_thresh

    def cell(point: Point) -> tuple[int, int] | None:
        # Cells as floats first: a far origin over a tiny resolution may not be finite.
        x_cells = (point[0] - grid.origin[0]) / grid.resolution
        y_cells = (point[1] - grid.origin[1]) / grid.resolution
        if not (0 <= x_cells < cols and 0 <= y_cells < rows):
            return None
        return rows - 1 - math.floor(y_cells), math.floor(x_cells)

    for room in rooms.values():
        where: Where = ("rooms", room.id, "at")
        found = cell(room.at)
        if found is None:
            reader.add(where, f"room {room.id!r} at {list(room.at)} is off the grid")
        elif occupied(found):
            reader.add(
                where,
                f"room {room.id!r} at {list(room.at)} is on an occupied cell "
                f"(row {found[0]}, column {found[1]} of {grid.image.name})",
            )
    for i, door in enumerate(doors):
        if door is None:
            continue
        where = ("doors", i, "at")
        found = cell(door.at)
        if found is None:
            reader.add(where, f"door {door.id!r} at {list(door.at)} is off the grid")
        elif occupied(found):
            reader.add(
                where,
                f"door {door.id!r} at {list(door.at)} is on an occupied cell (row "
                f"{found[0]}, column {found[1]} of {grid.image.name}): the robot could "
                f"never pass it; open the doorway in the grid image, as wide as the door",
            )
