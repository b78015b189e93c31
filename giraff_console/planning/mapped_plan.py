"""A floor plan made from a map the robot built as it was driven (issue 29, §2.6.3).

`map save NAME` writes, side by side:

- NAME-map.yaml and NAME-map.pgm: the map as ROS map_server reads it, for any ROS tool;
- NAME.yaml: the floor plan, rooms and doors found in that map as `floorplan rooms`
  finds them in any scan (room_segmentation.py), each room the operator marked by its
  name, and the grid it plans on beside it;
- NAME-rooms.png: the rooms found, coloured, to check.

The plan's start room is the one the robot started mapping in, and its point and
heading the dock's: where the robot began is where the plan says it starts, so that
a console started on the plan later takes the robot to stand where it does (the
simulator's dock, a real robot's charger). Its markers are to be surveyed
(`giraff-console survey`), as for any plan without them.

Nothing is written unless all of it can be: every file is checked first, and a plan
that would not load is refused with its problems.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from giraff_console.planning.floorplan import FloorPlan, FloorPlanError, Point, load_floorplan
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.map_saving import MapSaveError, save_ros_map
from giraff_console.planning.output_files import OutputError, check_outputs
from giraff_console.planning.plan_writing import millimetres, write_floorplan
from giraff_console.planning.room_marks import MarkProblem
from giraff_console.planning.room_picture import draw_rooms, encode_png
from giraff_console.planning.room_segmentation import (
    MarkError,
    Segmentation,
    SegmentationError,
    scan_plan,
    segment_rooms,
)
from giraff_console.planning.route_planner import ROBOT_RADIUS_M
from giraff_console.planning.scan_grid import read_scan
from giraff_console.private_files import PRIVATE_FILE
from giraff_console.robot.odometry import Pose


class MappedPlanError(Exception):
    """Nothing was written; the message says why, in one line."""


@dataclass(frozen=True)
class MappedPlan:
    plan: FloorPlan  # as loaded from what was written
    written: tuple[Path, ...]
    notes: tuple[str, ...]  # what the operator should know of it


def mapped_files(to: Path) -> tuple[Path, Path, Path]:
    """The plan, the ROS map and the picture `map save` writes for `to`."""
    stem = to.with_suffix("") if to.suffix in (".yaml", ".yml") else to
    return (stem.with_name(f"{stem.name}.yaml"), stem.with_name(f"{stem.name}-map.yaml"),
            stem.with_name(f"{stem.name}-rooms.png"))  # fmt: skip


def write_mapped_plan(grid: OccupancyGrid, marks: Sequence[tuple[str, Point]],
                      dock: Pose | None, to: Path,
                      robot_radius: float = ROBOT_RADIUS_M) -> MappedPlan:  # fmt: skip
    """The map `grid`, saved, and the plan made of it, with the rooms at `marks`
    named and the start room at `dock`; MappedPlanError if it cannot be, with nothing
    written."""
    if to.is_dir():
        raise MappedPlanError(f"{to} is a folder: give the map a name (map save {to}/home)")
    plan_path, map_path, picture = mapped_files(to)
    image = map_path.with_suffix(".pgm")
    outputs = [
        ("the plan", plan_path),
        ("the plan's grid", plan_path.with_suffix(".pgm")),
        ("the map", map_path),
        ("its image", image),
        ("the rooms' picture", picture),
    ]
    try:
        check_outputs(outputs, [], False)
    except OutputError as error:
        raise MappedPlanError(str(error)) from None
    try:
        return _written(grid, marks, dock, plan_path, map_path, picture, robot_radius)
    except (MapSaveError, SegmentationError, FloorPlanError, OSError) as error:
        # None of them was there before (check_outputs): none is left half made.
        for _, path in outputs:
            path.unlink(missing_ok=True)
        raise MappedPlanError(_said(error)) from None


def _written(grid: OccupancyGrid, marks: Sequence[tuple[str, Point]], dock: Pose | None,
             plan_path: Path, map_path: Path, picture: Path,
             robot_radius: float) -> MappedPlan:  # fmt: skip
    save_ros_map(grid, map_path)
    written = [map_path, map_path.with_suffix(".pgm")]
    scan = read_scan(map_path)
    found, unused = _segmented(scan.grid, scan.cropped, marks, robot_radius)
    made = scan_plan(found, map_path, f"Mapped by driving round ({plan_path.stem})")
    start, on_floor = _start_room(found, dock)
    if start is not None and dock is not None:
        made.plan["start"] = start
        room = made.plan["rooms"][start]
        if on_floor:
            room["at"] = [millimetres(dock.x), millimetres(dock.y)]
        else:
            unused += (f"the dock ({dock.x:.2f}, {dock.y:.2f}) is not on the map's "
                       f"floor: {start}, the start room, keeps its own point",)  # fmt: skip
        room["heading"] = round(math.degrees(dock.heading) % 360.0, 1)
    written += write_floorplan(made, plan_path, None if found.redrawn else scan.spec)
    picture.write_bytes(encode_png(draw_rooms(found)))
    written.append(picture)
    for path in written:
        path.chmod(PRIVATE_FILE)  # what the robot writes is its owner's alone
    plan = load_floorplan(plan_path)
    notes = tuple(f"{map_path.name}: {note}" for note in (*scan.notes, *found.notes))
    return MappedPlan(plan, tuple(written), unused + notes)


def _segmented(grid: OccupancyGrid, cropped: bool, marks: Sequence[tuple[str, Point]],
               robot_radius: float) -> tuple[Segmentation, tuple[str, ...]]:  # fmt: skip
    """The rooms found, named by `marks`; a mark that falls in a room marked before it,
    or on no room, is left out and said so (the map has no wall where the operator saw
    one, or the robot stood in a doorway): the plan is still made, its other names kept,
    rather than the whole drive's map refused."""
    try:
        return segment_rooms(grid, robot_radius, cropped=cropped, marks=marks), ()
    except MarkError as error:
        placeable = (MarkProblem.SAME_ROOM, MarkProblem.OFF_ROOMS)
        if not all(issue.problem in placeable for issue in error.issues):
            raise
        dropped = {issue.name for issue in error.issues}
        kept = [mark for mark in marks if mark[0] not in dropped]
        notes = tuple(f"not named: {issue.detail}" for issue in error.issues)
        return segment_rooms(grid, robot_radius, cropped=cropped, marks=kept), notes


def _start_room(found: Segmentation, dock: Pose | None) -> tuple[str | None, bool]:
    """The room the dock is in, or nearest to it, and whether the dock is on its floor;
    None without a dock."""
    if dock is None:
        return None, False
    grid = found.grid
    rows, cols = grid.shape
    labels = found.labels
    # As grid.cell_of, without its refusal off the map: the nearest room's then.
    col = math.floor((dock.x - grid.origin[0]) / grid.resolution)
    row = rows - 1 - math.floor((dock.y - grid.origin[1]) / grid.resolution)
    on_floor = 0 <= row < rows and 0 <= col < cols and bool(labels[row, col])
    if on_floor:
        label = int(labels[row, col])
    else:
        # The dock against a wall, outside every room's cells: the nearest room's.
        where = np.argwhere(labels > 0)
        if not len(where):
            return None, False
        nearest = where[np.argmin(((where - np.array((row, col))) ** 2).sum(axis=1))]
        label = int(labels[nearest[0], nearest[1]])
    return next((room.id for room in found.rooms if room.label == label), None), on_floor


def _said(error: Exception) -> str:
    if isinstance(error, FloorPlanError):
        return "; ".join(str(problem) for problem in error.problems)
    if isinstance(error, OSError):
        return f"cannot write {error.filename or ''}: {error.strerror or error}"
    return str(error)
