"""An Open-RMF building map as the importer reads it: its items checked, with their lines.

traffic-editor writes a `.building.yaml` as YAML, and people edit it by hand too.
Whatever in it cannot be read is a problem at the line of the item it is
about, and whatever the import decides for the map is a note at its line, each as
`file:line: message`, all found in one pass (rmf_import.py reads the level with these).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NoReturn

from giraff_console.planning.floorplan import (
    FloorPlanError,
    Point,
    Problem,
    ProblemLog,
    Where,
    dotted,
    shown,
)
from giraff_console.planning.rmf_level import Lane


class BuildingError(FloorPlanError):
    """A building map that cannot be imported: every problem, and the notes made before."""

    def __init__(self, problems: list[Problem], notes: list[str]) -> None:
        super().__init__(problems)
        self.notes = notes


class BuildingSource(ProblemLog):
    """A building map's problems and notes, each at the line of the item it is about."""

    def __init__(self, path: Path, lines: dict[Where, int]) -> None:
        super().__init__(path, lines)
        self.noted: list[Problem] = []

    def note(self, where: Where, message: str) -> None:
        self.add(where, f"note: {message}")
        self.noted.append(self.problems.pop())

    @property
    def notes(self) -> list[str]:
        return [str(note) for note in sorted(self.noted, key=lambda note: note.line or 0)]

    def line(self, where: Where) -> int | None:
        while where and where not in self.lines:
            where = where[:-1]
        return self.lines.get(where)

    def fail(self, where: Where, message: str) -> NoReturn:
        self.add(where, message)
        raise BuildingError(self._in_order(), self.notes)

    def check(self) -> None:
        if self.problems:
            raise BuildingError(self._in_order(), self.notes)

    def _in_order(self) -> list[Problem]:
        """The problems in the order of their lines, as the notes are (sorted keeps the
        order they were found in for one line)."""
        return sorted(self.problems, key=lambda problem: problem.line or 0)

    def items(self, level: dict, where: Where, key: str) -> list:
        """The level's list under `key`; none if it is missing or not a list."""
        raw = level.get(key)
        if raw is not None and not isinstance(raw, list):
            self.add((*where, key), f"{dotted((*where, key))} should be a list, not {raw!r:.60}")
        return raw if isinstance(raw, list) else []

    def edge(self, item: Any, where: Where, count: int) -> tuple[int, int, dict] | None:
        """A lane, door, wall or measurement: [v1, v2, {parameters}], with its vertex
        indices."""
        good = isinstance(item, list) and len(item) in (2, 3)
        params = item[2] if good and len(item) == 3 else {}
        good = good and isinstance(params, dict)
        if not good or not all(is_index(end, count) for end in item[:2]):
            self.add(
                where,
                f"{dotted(where)} should be [v1, v2, {{parameters}}] with v1 and v2 "
                f"from 0 to {count - 1}, not {item!r:.80}",
            )
            return None
        return item[0], item[1], params


def param(params: dict, key: str) -> Any:
    """A parameter's value: traffic-editor writes each one as [type, value]."""
    value = params.get(key)
    return value[1] if isinstance(value, list) and len(value) == 2 else None


def is_index(value: Any, count: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < count


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def read_vertices(
    source: BuildingSource, raw: Any, where: Where, shape: str | None = None
) -> tuple[list[Point | None], list[str], list[dict]]:
    """Each vertex's position as written, its name ("" if unnamed) and its parameters;
    None for a bad one's position. `shape` is a vertex's as the coordinate system writes
    it, for the problem a bad one is (default `[x, y, z, name, {parameters}]`)."""
    shape = shape or "[x, y, z, name, {parameters}]"
    if not isinstance(raw, list) or not raw:
        source.fail((*where, "vertices"), f"{dotted(where)} has no vertices")
    points: list[Point | None] = []
    names: list[str] = []
    params: list[dict] = []
    for i, item in enumerate(raw):
        at = (*where, "vertices", i)
        name = item[3] if isinstance(item, list) and len(item) > 3 else ""
        if isinstance(name, int) and not isinstance(name, bool):
            name = str(name)  # a hand-written name such as 101, which YAML reads as a number
        extra = item[4] if isinstance(item, list) and len(item) > 4 else {}
        good = isinstance(item, list) and len(item) >= 2 and all(map(is_number, item[:2]))
        if not good or not isinstance(name, str):
            source.add(at, f"{dotted(at)} should be {shape}, not {item!r}")
            points.append(None)
            names.append("")
            params.append({})
            continue
        points.append((float(item[0]), float(item[1])))
        names.append(name)
        params.append(extra if isinstance(extra, dict) else {})
    return points, names, params


def read_scale(
    source: BuildingSource, raw: list, where: Where, points: list[Point | None]
) -> float | None:
    """Metres a pixel: the mean over the level's measurements of distance / pixel length,
    as RMF's map generator works it out. RMF carries on in pixels without one; a robot
    among people must not, so no measurement is an error. None if no measurement is good:
    each bad one is a problem, and the level is read on for the rest of them."""
    if not raw:
        source.add(where, f"{dotted(where)} has no measurements to turn pixels into metres")
    ratios = []
    for i, item in enumerate(raw):
        at = (*where, "measurements", i)
        edge = source.edge(item, at, len(points))
        ends = [points[v] for v in edge[:2]] if edge is not None else [None]
        if None in ends:
            continue  # already a problem
        assert edge is not None  # else ends would be [None]
        length = math.dist(*ends)
        distance = param(edge[2], "distance")
        if not (is_number(distance) and distance > 0 and length > 0):
            apart = f"should join two places {{distance: [3, metres]}} apart, not {item!r:.80}"
            source.add(at, f"{dotted(at)} {apart}")
        else:
            ratios.append(distance / length)
    return sum(ratios) / len(ratios) if ratios else None


def read_lanes(
    source: BuildingSource, raw: list, where: Where, count: int, graph: int | None
) -> tuple[list[Lane], set[int]]:
    """The lanes of `graph` (of every graph, without one), and the vertices any lane
    touches. A lane's graph is its `graph_idx`, 0 when it has none, as RMF reads it."""
    lanes: list[Lane] = []
    on_lanes: set[int] = set()
    graphs: set[int] = set()
    for i, item in enumerate(raw):
        at = (*where, "lanes", i)
        edge = source.edge(item, at, count)
        if edge is None:
            continue
        index = param(edge[2], "graph_idx") if "graph_idx" in edge[2] else 0
        if not is_index(index, 10**9):
            source.add(at, f"{dotted(at)}'s graph_idx should be [2, n], n a whole number, "
                       f"not {shown(edge[2].get('graph_idx'))}")  # fmt: skip
            continue
        graphs.add(index)
        on_lanes.update(edge[:2])
        if graph is None or index == graph:
            lanes.append(Lane((edge[0], edge[1]), at))
    if graph is not None and graph not in graphs and not source.problems:
        there = f"graphs {', '.join(map(str, sorted(graphs)))}" if graphs else "no lanes"
        source.add((*where, "lanes"), f"{dotted(where)} has no lanes in graph {graph} "
                   f"(it has {there})")  # fmt: skip
    return lanes, on_lanes


def read_polygons(
    source: BuildingSource, raw: dict, where: Where, key: str, count: int
) -> list[list[int]]:
    """The level's floors (or holes): each {vertices: [v1, v2, v3, ...], parameters}."""
    polygons = []
    for i, item in enumerate(source.items(raw, where, key)):
        at = (*where, key, i)
        corners = item.get("vertices") if isinstance(item, dict) else None
        if not (isinstance(corners, list) and len(corners) >= 3
                and all(is_index(v, count) for v in corners)):  # fmt: skip
            source.add(at, f"{dotted(at)} should be {{vertices: [v1, v2, v3, ...]}}, at least "
                       f"3 vertices from 0 to {count - 1}, not {shown(item)}")  # fmt: skip
            continue
        polygons.append(corners)
    return polygons
