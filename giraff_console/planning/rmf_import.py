"""Floor plans made from Open-RMF building maps (`*.building.yaml`, drawn in traffic-editor).

A building whose robots already run under Open-RMF has a map of it, and importing that
map saves drawing the rooms and doors again by hand (thesis §2.6.2). RMF's map is a graph
of lanes between vertices, with doors drawn as segments across lanes; ours is rooms
joined by doors. floorplans/README.md ("Importing") is the contract for the mapping:

- a named vertex is a room, at the vertex; unnamed vertices are only waypoints;
- a chain of lanes from one room to another through unnamed vertices only is contracted
  into one door between the two rooms: RMF's door across a lane of the chain, if there
  is one, else a door of the default width halfway along the chain;
- positions are the metres RMF's own map generator works out: with
  `coordinate_system: reference_image` (traffic-editor's default) vertices are pixels of
  the floor drawing, y down, so y is flipped and scaled by the mean of the level's
  measurements (distance over pixel length); `cartesian_meters` are metres already.

Whatever cannot be mapped without guessing (a chain crossing two doors, a door on the way
between several pairs of rooms) is an error that says which vertex to name. Before
anything is written the result goes through the floor plan loader's checks, so an import
never leaves a file that `floorplan check` would refuse.
"""

from __future__ import annotations

import errno
import heapq
import math
import re
import shutil
import tempfile
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any, NoReturn, cast

import yaml

from giraff_console.planning.floorplan import (
    FloorPlanError,
    GridSpec,
    Point,
    Problem,
    ProblemLog,
    Where,
    _dotted,
    check_floorplan,
)
from giraff_console.planning.ros_map import grid_section, read_yaml

_NOT_ID = re.compile(r"[^A-Za-z0-9_-]+")
_SYSTEMS = ("reference_image", "cartesian_meters")


@dataclass(frozen=True)
class ImportedPlan:
    source: Path
    level: str
    plan: dict[str, Any]  # a floor plan in our schema, ready to be written as YAML
    notes: list[str]  # what was left out, for the operator to know
    header: str  # the comment that opens the written file


@dataclass(frozen=True)
class _RmfDoor:
    id: str
    ends: tuple[Point, Point]
    where: Where


def sanitise_id(text: str) -> str:
    """`text` made an id: each run of characters other than letters, digits, '-' and '_'
    becomes one '-', none at either end, at most 64 characters ("Room 101" -> "Room-101")."""
    return _NOT_ID.sub("-", text).strip("-")[:64].rstrip("-")


class _Source(ProblemLog):
    """A building map's problems, each at the line of the item it is about."""

    def fail(self, where: Where, message: str) -> NoReturn:
        self.add(where, message)
        raise FloorPlanError(self.problems)

    def check(self) -> None:
        if self.problems:
            raise FloorPlanError(self.problems)

    def items(self, level: dict, where: Where, key: str) -> list:
        """The level's list under `key`; none if it is missing or not a list."""
        raw = level.get(key)
        if raw is not None and not isinstance(raw, list):
            self.add((*where, key), f"{_dotted((*where, key))} should be a list, not {raw!r:.60}")
        return raw if isinstance(raw, list) else []

    def edge(self, item: Any, where: Where, count: int) -> tuple[int, int, dict] | None:
        """A lane, door or measurement: [v1, v2, {parameters}], with its vertex indices."""
        good = isinstance(item, list) and len(item) in (2, 3)
        params = item[2] if good and len(item) == 3 else {}
        good = good and isinstance(params, dict)
        if not good or not all(_is_index(end, count) for end in item[:2]):
            self.add(
                where,
                f"{_dotted(where)} should be [v1, v2, {{parameters}}] with v1 and v2 "
                f"from 0 to {count - 1}, not {item!r:.80}",
            )
            return None
        return item[0], item[1], params


def _param(params: dict, key: str) -> Any:
    """A parameter's value: traffic-editor writes each one as [type, value]."""
    value = params.get(key)
    return value[1] if isinstance(value, list) and len(value) == 2 else None


def _is_index(value: Any, count: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < count


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _m(value: float) -> float:
    return round(value, 3) + 0.0  # millimetres are plenty; + 0.0 turns -0.0 into 0.0


def read_building(
    path: str | Path, level: str | None = None, name: str | None = None
) -> ImportedPlan:
    """The floor plan for one level of the Open-RMF building map at `path` (the only
    level unless `level` names one); raises FloorPlanError listing what is wrong."""
    path = Path(path)
    document, lines = read_yaml(path)
    source = _Source(path, lines)
    system = document.get("coordinate_system", "reference_image")
    if system not in _SYSTEMS:
        message = f"coordinate_system {system!r} is not supported (only {' and '.join(_SYSTEMS)})"
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
        source.fail(where, f"{_dotted(where)} should be a mapping of keys, not {raw!r:.60}")

    points, names = _vertices(source, raw.get("vertices"), where)
    if system == "reference_image":
        scale = _scale(source, source.items(raw, where, "measurements"), where, points)
        # Pixel rows grow downwards; RMF's map generator flips y to make the map frame.
        points = [None if p is None else (p[0] * scale, -p[1] * scale) for p in points]
        frame = f"reference_image: {scale:.6g} m a pixel, y flipped"
    else:
        frame = "cartesian_meters"
    neighbours = _lanes(source, source.items(raw, where, "lanes"), where, len(points))
    doors = _rmf_doors(source, source.items(raw, where, "doors"), where, points)
    rooms = _rooms(source, names, where)
    source.check()
    located = cast(list[Point], points)  # a bad vertex would have failed the check

    chains = _chains(set(rooms), neighbours, located)
    plan_doors, notes = _doors(source, chains, rooms, doors, located)
    source.check()
    building = document.get("name", document.get("building_name"))
    if not isinstance(building, str):
        building = path.name.removesuffix(".yaml").removesuffix(".building")
    plan = {
        "name": name if name is not None else f"{building}, level {level}",
        "rooms": {room_id: _room(room_id, names[i], located[i]) for i, room_id in rooms.items()},
        "doors": plan_doors,
    }
    header = (
        '# Made by `giraff-console floorplan import` (floorplans/README.md, "Importing")\n'
        f"# from {path.name}, level {level}: {frame}.\n"
    )
    return ImportedPlan(path, level, plan, notes, header)


def _vertices(source: _Source, raw: Any, where: Where) -> tuple[list[Point | None], list[str]]:
    """Each vertex's position as written and its name ("" if unnamed); None for a bad one."""
    if not isinstance(raw, list) or not raw:
        source.fail((*where, "vertices"), f"{_dotted(where)} has no vertices")
    points: list[Point | None] = []
    names: list[str] = []
    for i, item in enumerate(raw):
        at = (*where, "vertices", i)
        name = item[3] if isinstance(item, list) and len(item) > 3 else ""
        if isinstance(name, int) and not isinstance(name, bool):
            name = str(name)  # a hand-written name such as 101, which YAML reads as a number
        good = isinstance(item, list) and len(item) >= 2 and all(map(_is_number, item[:2]))
        if not good or not isinstance(name, str):
            source.add(at, f"{_dotted(at)} should be [x, y, z, name, {{parameters}}], not {item!r}")
            points.append(None)
            names.append("")
            continue
        points.append((float(item[0]), float(item[1])))
        names.append(name)
    return points, names


def _scale(source: _Source, raw: list, where: Where, points: list[Point | None]) -> float:
    """Metres a pixel: the mean over the level's measurements of distance / pixel length,
    as RMF's map generator works it out. RMF carries on in pixels without one; a robot
    among people must not, so no measurement is an error."""
    if not raw:
        source.fail(where, f"{_dotted(where)} has no measurements to turn pixels into metres")
    ratios = []
    for i, item in enumerate(raw):
        at = (*where, "measurements", i)
        edge = source.edge(item, at, len(points))
        ends = [points[v] for v in edge[:2]] if edge is not None else [None]
        if None in ends:
            continue  # already a problem
        assert edge is not None  # else ends would be [None]
        length = math.dist(*ends)
        distance = _param(edge[2], "distance")
        if not (_is_number(distance) and distance > 0 and length > 0):
            apart = f"should join two places {{distance: [3, metres]}} apart, not {item!r:.80}"
            source.add(at, f"{_dotted(at)} {apart}")
        else:
            ratios.append(distance / length)
    source.check()
    return sum(ratios) / len(ratios)


def _lanes(source: _Source, raw: list, where: Where, count: int) -> dict[int, set[int]]:
    """The vertices each vertex shares a lane with. Every graph's lanes count, and both
    ways: a route between rooms is the building's, not one fleet's."""
    neighbours: dict[int, set[int]] = {}
    for i, item in enumerate(raw):
        edge = source.edge(item, (*where, "lanes", i), count)
        if edge is not None:
            neighbours.setdefault(edge[0], set()).add(edge[1])
            neighbours.setdefault(edge[1], set()).add(edge[0])
    return neighbours


def _rmf_doors(source: _Source, raw: list, where: Where, points: list[Point | None]) -> list:
    doors: list[_RmfDoor] = []
    for i, item in enumerate(raw):
        at = (*where, "doors", i)
        edge = source.edge(item, at, len(points))
        if edge is None:
            continue
        start, end, name = points[edge[0]], points[edge[1]], _param(edge[2], "name")
        if not isinstance(name, str) or not sanitise_id(name):
            source.add(at, f"{_dotted(at)} needs a name of letters or digits, not {name!r}")
        elif start is not None and end is not None:
            doors.append(_RmfDoor(sanitise_id(name), (start, end), at))
    return doors


def _rooms(source: _Source, names: list[str], where: Where) -> dict[int, str]:
    """The room id of each named vertex, by vertex index."""
    rooms: dict[int, str] = {}
    first: dict[str, int] = {}
    for i, name in enumerate(names):
        if not name:
            continue
        at = (*where, "vertices", i)
        room_id = sanitise_id(name)
        if not room_id:
            source.add(at, f"vertex {i}'s name {name!r} has no letters or digits for a room id")
        elif room_id in first:
            other = f"vertices {first[room_id]} ({names[first[room_id]]!r}) and {i} ({name!r})"
            source.add(at, f"{other} would both be room {room_id!r}: rename one of them")
        else:
            first[room_id] = i
            rooms[i] = room_id
    if not rooms and not source.problems:
        source.fail(where, f"{_dotted(where)} has no named vertices to make rooms of")
    return rooms


def _chains(
    named: set[int], neighbours: dict[int, set[int]], points: list[Point]
) -> dict[tuple[int, int], list[int]]:
    """For each pair of named vertices (a < b) joined by lanes whose inner vertices are
    all unnamed, the shortest such chain of vertices, from a to b."""
    chains: dict[tuple[int, int], list[int]] = {}
    for a in sorted(named):
        # Dijkstra from a that stops at every other named vertex: rooms end chains.
        distance, previous, queue = {a: 0.0}, {}, [(0.0, a)]
        while queue:
            d, v = heapq.heappop(queue)
            if d > distance[v] or (v != a and v in named):
                continue
            for w in neighbours.get(v, ()):
                step = d + math.dist(points[v], points[w])
                if step < distance.get(w, math.inf):
                    distance[w], previous[w] = step, v
                    heapq.heappush(queue, (step, w))
        for b in sorted(named & distance.keys()):
            if b > a:
                chain = [b]
                while chain[-1] != a:
                    chain.append(previous[chain[-1]])
                chains[(a, b)] = chain[::-1]
    return chains


def _crosses(p: Point, q: Point, r: Point, s: Point) -> bool:
    """Whether segment pq meets segment rs; parallel ones never do, as in RMF's own check."""
    (ex, ey), (fx, fy) = (q[0] - p[0], q[1] - p[1]), (s[0] - r[0], s[1] - r[1])
    wx, wy = r[0] - p[0], r[1] - p[1]
    det = ex * fy - ey * fx
    if abs(det) < 1e-12:
        return False
    along_pq, along_rs = (wx * fy - wy * fx) / det, (wx * ey - wy * ex) / det
    return 0 <= along_pq <= 1 and 0 <= along_rs <= 1


def _halfway(chain: list[Point]) -> Point:
    """The point halfway along a polyline: on the lanes, where the robot would pass."""
    steps = [math.dist(a, b) for a, b in pairwise(chain)]
    left = sum(steps) / 2
    for (a, b), step in zip(pairwise(chain), steps, strict=True):
        if step >= left:
            t = left / step if step else 0.0
            return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
        left -= step
    return chain[-1]  # rounding left a sliver past the last step


def _doors(
    source: _Source,
    chains: dict[tuple[int, int], list[int]],
    rooms: dict[int, str],
    rmf_doors: list[_RmfDoor],
    points: list[Point],
) -> tuple[list[dict[str, Any]], list[str]]:
    """Our doors, one a chain, and notes on the RMF doors no chain goes through."""
    crossing: dict[tuple[int, int], list[_RmfDoor]] = {}
    for pair, chain in chains.items():
        lanes = [(points[u], points[v]) for u, v in pairwise(chain)]
        crossing[pair] = [
            door for door in rmf_doors if any(_crosses(*lane, *door.ends) for lane in lanes)
        ]
    for door in rmf_doors:
        pairs = [f"{rooms[a]}-{rooms[b]}" for (a, b), on in crossing.items() if door in on]
        if len(pairs) > 1:
            fix = "name the vertex where their lanes meet, so that the door joins two rooms"
            source.add(door.where, f"door {door.id!r} is between {', '.join(pairs)}: {fix}")
    doors: list[dict[str, Any]] = []
    for (a, b), chain in chains.items():
        between = [rooms[a], rooms[b]]
        on = crossing[(a, b)]
        if len(on) > 1:
            names = ", ".join(repr(door.id) for door in on)
            crossed = f"the lanes from {between[0]!r} to {between[1]!r} cross doors {names}"
            source.add(on[1].where, f"{crossed}: name a vertex between the doors")
        elif on:
            (x1, y1), (x2, y2) = on[0].ends
            at = [_m((x1 + x2) / 2), _m((y1 + y2) / 2)]
            width = _m(math.dist(*on[0].ends))
            doors.append({"between": between, "at": at, "width": width, "id": on[0].id})
        else:
            x, y = _halfway([points[v] for v in chain])
            doors.append({"between": between, "at": [_m(x), _m(y)], "id": "-".join(between)})
    used = {door.id for on in crossing.values() for door in on}
    left_out = [door.id for door in rmf_doors if door.id not in used]
    return doors, [f"door {id!r} crosses no lane between two rooms: left out" for id in left_out]


def _room(room_id: str, name: str, point: Point) -> dict[str, Any]:
    room: dict[str, Any] = {"at": [_m(point[0]), _m(point[1])]}
    if name != room_id:
        room = {"label": name, **room}  # the name as RMF shows it, when the id had to change
    return room


def write_floorplan(
    imported: ImportedPlan, out: str | Path, grid: GridSpec | None = None, force: bool = False
) -> list[Path]:
    """Write `imported` to `out`, with `grid`'s image copied next to it as `out`'s name
    with the image's suffix; return the files written. Nothing is written if the result
    would not load (FloorPlanError naming the problems) or, without `force`, if a file to
    write exists already (FileExistsError)."""
    out = Path(out)
    image = out.with_suffix(grid.image.suffix) if grid is not None else None
    copy_image = (
        grid is not None
        and image is not None
        and not (image.exists() and image.samefile(grid.image))
    )
    for target in (out, image if copy_image else None):
        if target is not None and target.exists() and not force:
            raise FileExistsError(errno.EEXIST, "already exists", str(target))
    plan = dict(imported.plan)
    if grid is not None:
        # Checked against the map's own image, so that nothing is copied for a plan refused.
        plan["grid"] = grid_section(grid, str(grid.image.resolve()))
    with tempfile.TemporaryDirectory() as directory:
        trial = Path(directory) / out.name
        trial.write_text(_text(imported.header, plan), encoding="utf-8")
        problems = check_floorplan(trial)
    if problems:
        raise FloorPlanError(
            [Problem(imported.source, None, problem.message) for problem in problems]
            + [Problem(out, None, "not written: the imported floor plan would not load")]
        )
    written = []
    if grid is not None and image is not None:
        plan["grid"] = grid_section(grid, image.name)
        if copy_image:
            shutil.copyfile(grid.image, image)
            written.append(image)
    out.write_text(_text(imported.header, plan), encoding="utf-8")
    return [out, *written]


def _text(header: str, plan: dict[str, Any]) -> str:
    body = yaml.safe_dump(plan, sort_keys=False, default_flow_style=None, allow_unicode=True)
    return header + body
