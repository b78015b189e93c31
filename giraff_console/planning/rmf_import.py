"""Floor plans made from Open-RMF building maps (`*.building.yaml`, drawn in traffic-editor).

A building whose robots already run under Open-RMF has a map of it, and importing that
map saves drawing the rooms and doors again by hand (thesis §2.6.2). floorplans/README.md
("Importing") is the contract. This module reads one level of the map as traffic-editor
writes it (rmf_source.py checks each item): its vertices (named ones are rooms), its
lanes (every fleet's, or one graph's), doors, walls, floors and holes, in metres as
RMF's own map generator works them out (a geo-referenced map's longitudes and latitudes
on the plane tangent at the building's middle instead: rmf_wgs84.py). Names that would
clash are renamed (`waiting_area`, `waiting_area-2`). rmf_spaces.py then finds the rooms
and doors; with walls, rmf_walls.py draws the grid, which is written next to the floor
plan.

A real map is imported as it is: whatever the importer had to decide for it is told in
a note at its line, and only what cannot be mapped at all (a vertex that is not one, a
lane to a vertex that does not exist, pixels with no measurement to scale them) is an
error. Every problem and note is found in one pass, each as `file:line: message`. Before
anything is written the result goes through the floor plan loader's checks, so an import
never leaves a file that `floorplan check` would refuse.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, cast

from giraff_console.file_limits import CountLimit, too_many
from giraff_console.planning.floorplan import (
    Point,
    Where,
    dotted,
)
from giraff_console.planning.plan_writing import MadePlan
from giraff_console.planning.rmf_lanes import lane_graph
from giraff_console.planning.rmf_level import ID_LENGTH, Lane, Level, Named, RmfDoor, free_id
from giraff_console.planning.rmf_source import (
    BuildingSource,
    param,
    read_lanes,
    read_polygons,
    read_scale,
    read_vertices,
)
from giraff_console.planning.rmf_spaces import find_rooms
from giraff_console.planning.rmf_walls import draw_floor, draw_grid
from giraff_console.planning.rmf_wgs84 import in_metres
from giraff_console.planning.ros_map import read_yaml

_NOT_ID = re.compile(r"[^A-Za-z0-9_-]+")
_SYSTEMS = ("reference_image", "cartesian_meters", "wgs84")


def sanitise_id(text: str) -> str:
    """`text` made an id: each run of characters other than letters, digits, '-' and '_'
    becomes one '-', none at either end, at most 64 characters ("Room 101" -> "Room-101")."""
    return _NOT_ID.sub("-", text).strip("-")[:ID_LENGTH].rstrip("-")


# A level's items and the limit (file_limits.py) each counts against: its vertices, the
# lanes and walls between them, as the points of a route; its doors, as a plan's doors.
_COUNTED: tuple[tuple[str, CountLimit], ...] = (
    ("vertices", "waypoints"), ("lanes", "waypoints"), ("walls", "waypoints"),
    ("doors", "doors"),
)  # fmt: skip


def read_building(
    path: str | Path, level: str | None = None, name: str | None = None, graph: int | None = None
) -> MadePlan:
    """The floor plan for one level of the Open-RMF building map at `path` (the only
    level unless `level` names one), from every fleet's lanes or only those of `graph`;
    raises BuildingError (a FloorPlanError) listing what is wrong."""
    path = Path(path)
    document, lines = read_yaml(path)
    source = BuildingSource(path, lines)
    system = document.get("coordinate_system", "reference_image")
    if system not in _SYSTEMS:
        message = f"coordinate_system {system!r} is not supported (only {', '.join(_SYSTEMS)})"
        source.fail(("coordinate_system",), message)
    levels = document.get("levels")
    if not isinstance(levels, dict) or not levels:
        source.fail(("levels",), "no levels: is it an Open-RMF building map?")
    by_name = {str(key): value for key, value in levels.items()}
    if level is None and len(by_name) > 1:
        source.fail(("levels",), f"several levels ({', '.join(by_name)}): choose one (--level)")
    if level is not None and level not in by_name:
        source.fail(("levels",), f"no level called {level!r} (levels: {', '.join(by_name)})")
    level = level if level is not None else next(iter(by_name))
    where: Where = ("levels", level)
    raw = by_name[level]
    if not isinstance(raw, dict):
        source.fail(where, f"{dotted(where)} should be a mapping of keys, not {raw!r:.60}")
    # Counted before any is read: finding the rooms grows faster than the items do.
    for key, limit in _COUNTED:
        items = raw.get(key)
        crowded = too_many(len(items), limit, key) if isinstance(items, list) else None
        if crowded is not None:
            source.fail((*where, key), f"{dotted((*where, key))}: {crowded}")

    shape = "[longitude, latitude, z, name, {parameters}]" if system == "wgs84" else None
    points, names, params = read_vertices(source, raw.get("vertices"), where, shape)
    if system == "reference_image":
        scale = read_scale(source, source.items(raw, where, "measurements"), where, points)
        # Pixel rows grow downwards; RMF's map generator flips y to make the map frame.
        # Without a scale the measurements are problems: read on for the others.
        metres = 1.0 if scale is None else scale
        points = [None if p is None else (p[0] * metres, -p[1] * metres) for p in points]
        frame = f"reference_image: {metres:.6g} m a pixel, y flipped"
    elif system == "wgs84":
        points, frame = in_metres(source, points, by_name, where)
    else:
        frame = "cartesian_meters"
    count = len(points)
    lanes, on_lanes = read_lanes(source, source.items(raw, where, "lanes"), where, count, graph)
    door_edges = [
        (edge, (*where, "doors", i))
        for i, item in enumerate(source.items(raw, where, "doors"))
        if (edge := source.edge(item, (*where, "doors", i), count)) is not None
    ]
    walls = [
        (edge[0], edge[1])
        for i, item in enumerate(source.items(raw, where, "walls"))
        if (edge := source.edge(item, (*where, "walls", i), count)) is not None
    ]
    floors = read_polygons(source, raw, where, "floors", count)
    holes = read_polygons(source, raw, where, "holes", count)
    source.check()
    located = cast(list[Point], points)  # a bad vertex would have failed the check

    named = _named(source, names, params, located, where, lanes, on_lanes)
    doors = _doors(source, door_edges, located, {room.id for room in named})
    polygons = [[[located[v] for v in corners] for corners in kind] for kind in (floors, holes)]
    found = Level(located, named, lanes, doors, walls, *polygons)
    floor = draw_floor(found) if walls else None
    taken = {room.id for room in named} | {door.id for door in doors}
    layout = find_rooms(found, lane_graph(found), floor, taken)
    for at, message in layout.notes:
        source.note(at, message)
    if not layout.rooms and any(names):
        source.fail(where, f"{dotted(where)} has no rooms: each of its named vertices was "
                    "left out (the notes above say why)")  # fmt: skip
    if not layout.rooms:
        source.fail(where, f"{dotted(where)} has no named vertices, and no doors between "
                    "spaces, to make rooms of")  # fmt: skip
    building = document.get("name", document.get("building_name"))
    if not isinstance(building, str):
        building = path.name.removesuffix(".yaml").removesuffix(".building")
    plan: dict[str, Any] = {
        "name": name if name is not None else f"{building}, level {level}",
        "rooms": {
            room_id: {"label": label, "at": list(at)} if label is not None else {"at": list(at)}
            for room_id, (at, label) in layout.rooms.items()
        },
        "doors": layout.doors,
    }
    if layout.start is not None:
        plan["start"] = layout.start
    fleets = "every graph" if graph is None else f"graph {graph}"
    rooms_from = "walls and doors" if floor is not None else "lanes and doors"
    header = (
        '# Made by `giraff-console floorplan import` (floorplans/README.md, "Importing")\n'
        f"# from {path.name}, level {level}, in\n"
        f"# {frame};\n"
        f"# rooms found from its {rooms_from}, with the lanes of {fleets}.\n"
    )
    drawn = None
    if floor is not None:
        kept = {door["id"] for door in layout.doors}
        drawn = draw_grid(found, [i for i, door in enumerate(doors) if door.id in kept])
    made_from = {
        item: line for item, where in layout.made_from.items()
        if (line := source.line(where)) is not None
    }  # fmt: skip
    return MadePlan(path, plan, source.notes, header, drawn, made_from)


def _named(source: BuildingSource, names: list[str], params: list[dict], points: list[Point],
           where: Where, lanes: list[Lane], on_lanes: set[int]) -> list[Named]:  # fmt: skip
    """A room for each named vertex, but those only on lanes of graphs not chosen (other
    fleets' places); a name that is taken already is numbered."""
    chosen = {end for lane in lanes for end in lane.ends}
    named: list[Named] = []
    first: dict[str, int] = {}
    for i, name in enumerate(names):
        if not name:
            continue
        at = (*where, "vertices", i)
        if i in on_lanes and i not in chosen:
            source.note(at, f"vertex {i} ({name!r}) is only on lanes of other graphs than "
                        "the one chosen (--graph): left out")  # fmt: skip
            continue
        stem = sanitise_id(name) or f"vertex-{i}"
        if not sanitise_id(name):
            source.note(at, f"vertex {i}'s name {name!r} has no letters or digits: it is room "
                        f"{stem!r}")  # fmt: skip
        room_id = free_id(stem, first)
        if room_id != stem:
            other = first[stem]
            line = source.line((*where, "vertices", other))
            source.note(at, f"vertex {i} ({name!r}) would be room {stem!r}, as vertex {other} "
                        f"({names[other]!r}, line {line}) is: it is room {room_id!r}")  # fmt: skip
        first[room_id] = i
        charger = param(params[i], "is_charger") is True
        named.append(Named(room_id, name, i, points[i], charger, at))
    return named


def _doors(source: BuildingSource, edges: list[tuple[tuple[int, int, dict], Where]],
           points: list[Point], room_ids: set[str]) -> list[RmfDoor]:  # fmt: skip
    """The RMF doors, each with an id of its own: its name made an id, with `-door` after
    it if a room has it, numbered if another door has it."""
    doors: list[RmfDoor] = []
    first: dict[str, Where] = {}  # by id, the door that has it
    taken = set(room_ids)
    for (a, b, params), at in edges:
        name = param(params, "name")
        name = str(name) if isinstance(name, str | int) and not isinstance(name, bool) else ""
        stem = sanitise_id(name)
        if not stem:
            stem = f"door-{at[-1]}"
            source.note(at, f"door {at[-1]} has no name of letters or digits ({name!r}): it is "
                        f"door {stem!r}")  # fmt: skip
        named = stem
        if stem in room_ids:
            stem = sanitise_id(f"{stem}-door")
        door_id = free_id(stem, taken)
        taken.add(door_id)
        # One note a door, in the names the map gave it.
        clashes = ["the name of a room"] if named in room_ids else []
        if door_id != stem and stem in first:
            clashes.append(f"the name of another door (line {source.line(first[stem])})")
        if clashes:
            source.note(at, f"door {named!r} has {' and '.join(clashes)}: it is door {door_id!r}")
        first[door_id] = at
        doors.append(RmfDoor(door_id, (points[a], points[b]), at))
    return doors
