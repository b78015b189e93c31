"""The checks `floorplan check` runs on a plan's markers (floorplans/README.md,
"Landmarks"), each reported at the key it is about: an id its family has and no other
marker has; on a wall (an outline's edge or a door frame, or without outlines an edge of
the grid's occupied cells, where the simulator's walls are), flat on it and facing into
a room; its square on the wall, not over a doorway or round a corner; and clear of the
other markers' paper.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from giraff_console.planning.floorplan import DOOR_TOLERANCE_M, FloorPlan, Marker, Where, shown
from giraff_console.planning.landmarks import (
    FACING_TOLERANCE_DEG,
    WALL_TOLERANCE_M,
    MarkerWalls,
    angle_between,
    cells,
    facing_error,
    fit_on_walls,
    id_count,
    marker_walls,
    room_in_front,
    unit,
    wall_direction,
)


def landmark_problems(
    family: str | None,
    size: float | None,
    markers: Sequence[tuple[int, Marker]],
    plan: FloorPlan | None,
) -> list[tuple[Where, str]]:
    """Every problem with a plan's markers, each at the key it is about. `markers` are
    those that read well, each with its index in the file; `plan` has the rooms and doors
    (and its grid, if it has one) to check them against, or is None when those did not
    read well."""
    problems: list[tuple[Where, str]] = []
    count = None
    if family is not None:
        try:
            count = id_count(family)
        except ValueError as error:
            problems.append((("landmarks", "family"), str(error)))
    first: dict[int, int] = {}
    for i, marker in markers:
        where: Where = ("landmarks", "markers", i, "id")
        if count is not None and marker.id >= count:
            problems.append(
                (
                    where,
                    f"marker id {shown(marker.id)} is beyond {family}'s {count} ids "
                    f"(0 to {count - 1})",
                )
            )
        if marker.id in first:
            problems.append(
                (
                    where,
                    f"duplicate marker id {shown(marker.id)} (also landmarks.markers"
                    f"[{first[marker.id]}]): the robot tells markers apart by id alone",
                )
            )
        first.setdefault(marker.id, i)
    if plan is not None:
        square = cells(family) if count is not None and family is not None else None
        problems += _wall_problems(plan, size, markers, square)
    return problems


def _wall_problems(
    plan: FloorPlan, size: float | None, markers: Sequence[tuple[int, Marker]], count: int | None
) -> list[tuple[Where, str]]:
    if not markers:
        return []
    try:
        walls = marker_walls(plan)
    except OSError:
        return []  # a grid image that cannot be read, reported at the grid's own key
    if not walls:
        why = "its grid has no occupied cells" if plan.grid else "give its rooms outlines"
        return [(("landmarks",), f"markers hang on walls, and this plan has none: {why}")]
    problems: list[tuple[Where, str]] = []
    for i, marker in markers:
        where: Where = ("landmarks", "markers", i)
        problem = _wall_problem(plan, walls, marker, size)
        if problem is not None:
            problems.append(((*where, problem[0]), problem[1]))
    if size is not None:
        # The paper round each square must stay clear too, or the detector loses its edge.
        reach = size * (count + 2) / count if count else size
        problems += _overlaps(markers, reach)
    return problems


def _wall_problem(
    plan: FloorPlan, walls: MarkerWalls, marker: Marker, size: float | None
) -> tuple[str, str] | None:
    """The first thing wrong with where a marker hangs, as (key, message), if any."""
    name = f"marker {marker.id} at {list(marker.at)}"
    fit = fit_on_walls(marker.at, marker.facing, walls)
    if fit.wall is None:
        for door in plan.doors:
            if math.dist(door.at, marker.at) <= door.width / 2 + DOOR_TOLERANCE_M:
                return "at", f"{name} is in the doorway of door {door.id!r}: put it beside it"
        return "at", (
            f"{name} is {fit.distance:.2f} m from the nearest wall (at most "
            f"{WALL_TOLERANCE_M} m): markers hang on walls"
        )
    error = facing_error(fit.wall, marker.facing)
    if error > FACING_TOLERANCE_DEG:
        normal = (wall_direction(fit.wall) + 90.0) % 180.0
        return "facing", (
            f"marker {marker.id} faces {marker.facing:g}°, {error:.1f}° from square to its "
            f"wall: it lies flat on it, facing {normal:g}° or {normal + 180:g}° "
            f"(within {FACING_TOLERANCE_DEG:g}°)"
        )
    if room_in_front(plan, marker.at, marker.facing) is None:
        other = room_in_front(plan, marker.at, marker.facing + 180.0)
        turn = (
            ""
            if other is None
            else (f": turn it round to face {(marker.facing + 180) % 360:g}°, into {other.id!r}")
        )
        return "facing", (f"marker {marker.id} faces {marker.facing:g}°, into no room{turn}")
    if size is not None:
        ux, uy = unit(wall_direction(fit.wall))
        for side in (-1, 1):
            end = (marker.at[0] + side * ux * size / 2, marker.at[1] + side * uy * size / 2)
            if walls.distances(end).min() > WALL_TOLERANCE_M:
                return "at", (
                    f"{name} overhangs the end of its wall (a doorway or a corner): "
                    f"its {size:g} m square must be on the wall"
                )
    return None


def _overlaps(markers: Sequence[tuple[int, Marker]], reach: float) -> list[tuple[Where, str]]:
    """Markers on the same side of a wall closer than their paper allows; swept in x, so
    that a plan of thousands of markers costs little."""
    problems: list[tuple[Where, str]] = []
    ordered = sorted(markers, key=lambda item: item[1].at[0])
    for k, (i, marker) in enumerate(ordered):
        for j, other in ordered[k + 1 :]:
            if other.at[0] - marker.at[0] >= reach:
                break
            gap = math.dist(marker.at, other.at)
            if gap < reach and angle_between(marker.facing, other.facing) < 90.0:
                first, second = (i, marker), (j, other)
                if j < i:
                    first, second = second, first
                problems.append(
                    (
                        ("landmarks", "markers", second[0], "at"),
                        f"marker {second[1].id} overlaps marker {first[1].id}: their centres are "
                        f"{gap:.2f} m apart, their papers {reach:.2f} m wide",
                    )
                )
    return problems
