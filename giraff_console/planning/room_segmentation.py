"""Rooms and doors found in a scanned map: a SLAM grid becomes a floor plan (issue 16).

A building mapped by a robot has a map_server grid but no floor plan: nobody has said
where the rooms are. The room-segmentation packages (ipa_room_segmentation's distance
segmentation, and watershed segmentations like it) find them from the distance
transform of the free space: how far each free cell is from the nearest wall. Rooms are
wide and the doorways between them narrow, so as the transform is cut at rising
heights the free space falls apart into pieces at the doorways, one piece to a room.

The rooms are found on the grid the plan will use: the map cropped to its floor and
cleared of specks (scan_grid.py), with unknown space not free, since the robot has not
seen it, and with the furniture standing on the floor taken for floor (floor_as_built.py,
issue 29): furniture makes no rooms, and the floor among it is its room's. The cut
rises from the least clearance the route planner leaves the robot (its radius and
CLEARANCE_M; narrower space is no room for it) upwards; where a piece splits into two,
each is a room of its own only if it rises well clear of the split (room_seeds.py): a
doorway between rooms is, a gap between an armchair and a bed is not. Each room's piece,
taken where it split off, seeds a watershed flood of the transform that grows it back
over the whole free space, so that neighbouring rooms meet at the narrowest
cross-section between them: the doorway (room_doors.py). A cut no person would call a
door (wider than a double door, or across a corridor) joins its two rooms
(room_openings.py). Rooms too small to be rooms (`MIN_ROOM_M2`, in the floor the scan
shows) are flooded by their neighbours instead, and rooms the planner cannot take the
robot to from the rest are left out. Rooms are named by the operator's marks
(room_marks.py), the rest room-N.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.defaults import MIN_ROOM_M2
from giraff_console.planning.floor_as_built import floor_as_built
from giraff_console.planning.floorplan import Door, Point
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.plan_writing import MadePlan, millimetres
from giraff_console.planning.room_doors import (
    Cells,
    Doorway,
    cells_of,
    doorways,
    least_clearance,
    passable,
)
from giraff_console.planning.room_marks import (
    Mark,
    MarkIssue,
    check_names,
    marked_rooms,
    room_names,
)
from giraff_console.planning.room_openings import join_openings
from giraff_console.planning.room_seeds import FINE_M, heights, room_seeds
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M
from giraff_console.planning.scan_grid import CROP_MARGIN_M, SPECK_M2, SPECK_SIDE_M, clean_grid

# Rooms whose centres lie within this of each other, top to bottom, are in one row when
# they are named in reading order.
ROW_GAP_M = 1.0
_CONNECTED = np.ones((3, 3), dtype=bool)  # eight neighbours: a room is one piece diagonally too


class SegmentationError(ValueError):
    """A map with nothing to segment; the message says why, in one line."""


class MarkError(SegmentationError):
    """Marks that cannot name the rooms found: each issue typed, with its own line."""

    def __init__(self, issues: Sequence[MarkIssue]) -> None:
        self.issues = tuple(issues)
        super().__init__("; ".join(issue.detail for issue in self.issues))


@dataclass(frozen=True)
class FoundRoom:
    id: str
    at: Point  # the point furthest from any wall: where the robot stands best
    label: int  # its cells' value in Segmentation.labels
    area_m2: float


@dataclass(frozen=True)
class Segmentation:
    grid: OccupancyGrid  # the map's grid cropped and cleaned, as the plan is to use it
    redrawn: bool  # whether `grid` differs from the map's, and so is written in its place
    labels: np.ndarray  # int32 per cell: a room's label, 0 for no room
    rooms: tuple[FoundRoom, ...]  # in reading order, top left first; marked or room-N
    doors: tuple[Door, ...]
    start: str  # the room with the most doors, where the robot is best placed to start
    notes: tuple[str, ...]  # what was changed or left out, for the operator to know


def segment_rooms(
    grid: OccupancyGrid,
    robot_radius: float = ROBOT_RADIUS_M,
    min_area: float = MIN_ROOM_M2,
    cropped: bool = False,
    marks: Sequence[Mark] = (),
) -> Segmentation:
    """The rooms of `grid` and the doors between them, found on `grid` cleaned of specks
    (scan_grid.py), which the Segmentation holds; SegmentationError if there is no room,
    or if the robot cannot be planned between any two rooms of several. `cropped` says
    that `grid` is already a crop of the map's (read_scan), and so differs from it.
    `marks` name rooms (room_marks.py): the room holding each mark's point is named by
    it; MarkError, listing every mark that cannot, if any cannot."""
    bad_names = check_names(marks)
    if bad_names:
        raise MarkError(bad_names)
    if not (grid.cells == FREE).any():
        raise SegmentationError("no free cell in the map: nothing to segment")
    cleaned = clean_grid(grid)
    grid = cleaned.grid
    floor = grid.cells == FREE
    clearance = _clearance(floor, grid.resolution)
    least = least_clearance(robot_radius)
    if clearance.max() <= least:
        raise SegmentationError(
            f"no free space wide enough for the robot ({robot_radius:g} m radius): the "
            f"route planner needs {_way(robot_radius):g} m: nothing to segment"
        )
    # Rooms are found on the floor as built, furniture taken away (floor_as_built.py),
    # and each keeps the scan's free floor among its furniture.
    built = floor_as_built(grid)
    built_clearance = _clearance(built, grid.resolution)
    seeds = room_seeds(built_clearance, least, grid.resolution)
    min_cells = min_area / grid.resolution**2
    walls = (grid.cells == OCCUPIED) & ~built  # occupied cells, not furniture
    while True:
        flooded = _flood(built_clearance, built, seeds, grid.resolution)
        room_of = join_openings(flooded, built_clearance, walls, grid.resolution)
        labels = np.where(floor, room_of[flooded], 0)
        # Small in the floor the scan shows: a room all furniture is no room either.
        areas = np.bincount(labels.ravel(), minlength=len(room_of))
        present = np.unique(seeds)
        small = [int(seed) for seed in present[present > 0] if areas[room_of[seed]] < min_cells]
        if not small:
            break
        seeds[np.isin(seeds, small)] = 0
    if not labels.any():
        raise SegmentationError(
            f"no room of {min_area:g} m² or more that the robot ({robot_radius:g} m radius) "
            "fits in: nothing to segment"
        )
    notes = []
    if cleaned.specks:
        notes.append(
            f"cleared {_count(cleaned.specks, 'speck')} ({cleaned.speck_cells} cells) from the "
            f"floor: holes in it up to {SPECK_M2:g} m² and {SPECK_SIDE_M:g} m across (scan "
            "noise, or the legs of tables and chairs), which the route planner would grow "
            "by the robot's radius into discs that shut doorways"
        )
    redrawn = cropped or cleaned.specks > 0
    if redrawn:
        changes = [f"cropped to its floor and {CROP_MARGIN_M:g} m round it"] * cropped
        changes += ["cleared of those specks"] * (cleaned.specks > 0)
        notes.append(f"the grid written with the plan is the map {' and '.join(changes)}; "
                     "the map itself is unchanged")  # fmt: skip
    return _plan(grid, redrawn, labels, clearance, robot_radius, notes, marks)


def _way(robot_radius: float) -> float:
    """How wide a way the route planner needs for a robot of `robot_radius`."""
    return round(2 * (robot_radius + CLEARANCE_M), 3)


def _count(number: int, thing: str) -> str:
    return f"{number} {thing}{'' if number == 1 else 's'}"


def _clearance(free: np.ndarray, resolution: float) -> np.ndarray:
    """Metres from each free cell's centre to the nearest other cell's centre (0 off the
    free space); the map's edge counts as a wall."""
    padded = np.pad(free.astype(np.uint8), 1)
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return distance[1:-1, 1:-1].astype(np.float64) * resolution


def _flood(clearance: np.ndarray, floor: np.ndarray, seeds: np.ndarray,
           step: float) -> np.ndarray:  # fmt: skip
    """Each floor cell labelled with the seed whose flood reaches it first; 0 for cells
    no seed reaches over the floor.

    The floods spread over the cells at least `height` from a wall, one cell a round,
    each as far as it can, while `height` falls a step at a time from the widest place
    to the walls: two rooms' floods meet where the way between them is narrowest, and
    where it is as narrow for a while (along a doorway's jambs), half-way along it.
    (scipy's watershed_ift would do this in one call, but leaves the cells it finds at
    one height to whichever flood it happened to take first, in bands round a building.)
    """
    labels = seeds.astype(np.uint16)  # cv2.dilate takes no int32; no building has 65535 rooms
    top = float(clearance.max())
    # Below FINE_M, a step at a time down from the top, as the cut (not on multiples of
    # the step, where cells' clearances fall on the line, and the floods' order with them).
    fine = np.arange(top, -step, -step)
    coarse = heights(FINE_M, top, step)[::-1] if top > FINE_M else np.array([])
    for height in np.concatenate([coarse, fine[fine < FINE_M]]):
        open_ = floor & (clearance >= height)
        while True:
            reached = cv2.dilate(labels, _CONNECTED.astype(np.uint8))
            new = open_ & (labels == 0) & (reached > 0)
            if not new.any():
                break
            labels[new] = reached[new]
    return labels.astype(np.int32)


def _plan(grid: OccupancyGrid, redrawn: bool, labels: np.ndarray, clearance: np.ndarray,
          robot_radius: float, notes: list[str],
          marks: Sequence[Mark]) -> Segmentation:  # fmt: skip
    """Put a door in every doorway between two rooms that the robot can be planned
    through, leave out the rooms it could not be planned to from the rest, and name the
    rooms left."""
    cells = cells_of(labels)
    points = {label: _at(grid, cells[label], clearance) for label in cells}
    sizes = {label: len(rows) for label, (rows, _) in cells.items()}
    joined, ways = passable(grid, points, sizes, doorways(grid, labels, clearance), robot_radius)
    area = grid.resolution**2
    if len(joined) < len(cells):
        left_out = sorted((label for label in cells if label not in joined),
                          key=lambda label: -sizes[label])  # fmt: skip
        if len(joined) < 2:
            raise SegmentationError(
                f"no two of the {len(cells)} rooms found are joined by a way "
                f"{_way(robot_radius):g} m wide, as the route planner needs for the robot "
                f"({robot_radius:g} m radius): is a doorway half shut, or the scan noisy?"
            )
        # The biggest few, for a note the operator reads rather than a list of specks.
        where = ", ".join(f"{sizes[label] * area:.1f} m² at ({points[label][0]:.1f}, "
                          f"{points[label][1]:.1f})" for label in left_out[:3])  # fmt: skip
        more = f" and {len(left_out) - 3} more" if len(left_out) > 3 else ""
        notes.append(f"left out {_count(len(left_out), 'piece')} of floor the robot cannot "
                     "reach from the rest (the route planner needs a way "
                     f"{_way(robot_radius):g} m wide): {where}{more}")  # fmt: skip
        labels = np.where(np.isin(labels, left_out), 0, labels)
    order = _reading_order(grid, {label: cells[label] for label in joined})
    named, issues = marked_rooms(grid, labels, marks)
    if issues:
        raise MarkError(issues)
    names = room_names(order, named)
    rooms = tuple(FoundRoom(names[label], points[label], label, sizes[label] * area)
                  for label in order)  # fmt: skip
    rank = {label: number for number, label in enumerate(order)}
    kept: list[tuple[int, int, Doorway]] = []
    for way in ways:
        first, second = sorted(way.rooms, key=rank.__getitem__)
        kept.append((first, second, way))
    kept.sort(key=lambda door: (rank[door[0]], rank[door[1]], door[2].at[0], -door[2].at[1]))
    doors: list[Door] = []
    for a, b, way in kept:
        door_id = f"{names[a]}-{names[b]}"
        # A second doorway between the same two rooms: room-7-room-10-2.
        alike = sum(door.between == (names[a], names[b]) for door in doors)
        door_id += f"-{alike + 1}" if alike else ""
        doors.append(Door(door_id, (names[a], names[b]), way.at, way.width, True))
    count = {room.id: sum(room.id in door.between for door in doors) for room in rooms}
    start = max(rooms, key=lambda room: count[room.id]).id
    return Segmentation(grid, redrawn, labels, rooms, tuple(doors), start, tuple(notes))


def _reading_order(grid: OccupancyGrid, cells: dict[int, Cells]) -> list[int]:
    """The rooms as a page is read: in rows from the top of the map, each row from the
    left. A room starts a new row when its centre is more than ROW_GAP_M below the
    centre of the last one's, so that a row of rooms alike stays one row however their
    furniture moves their centres."""
    centres = {label: _centre(grid, *cells[label]) for label in cells}
    rows_of: list[list[int]] = []
    last_y = math.inf
    for label in sorted(cells, key=lambda label: -centres[label][1]):
        if last_y - centres[label][1] > ROW_GAP_M or not rows_of:
            rows_of.append([])
        rows_of[-1].append(label)
        last_y = centres[label][1]
    return [label for row in rows_of for label in sorted(row, key=lambda label: centres[label][0])]


def _centre(grid: OccupancyGrid, rows: np.ndarray, cols: np.ndarray) -> Point:
    """The mean of the cells' centres, metres in the map frame."""
    x = grid.origin[0] + (float(cols.mean()) + 0.5) * grid.resolution
    y = grid.origin[1] + (grid.shape[0] - float(rows.mean()) - 0.5) * grid.resolution
    return x, y


def _at(grid: OccupancyGrid, cells: Cells, clearance: np.ndarray) -> Point:
    """The centre of the room's cell furthest from any wall; of several as far (within
    half a cell), the one nearest the room's middle. Only its main floor counts: floor
    shut in among its furniture is the room's too, but the robot cannot get there."""
    rows, cols = _main_floor(cells)
    room = clearance[rows, cols]
    best = room >= room.max() - grid.resolution / 2
    rows, cols = rows[best], cols[best]
    middle = np.hypot(rows - rows.mean(), cols - cols.mean())
    i = int(np.argmin(middle))
    x, y = grid.centre_of(int(rows[i]), int(cols[i]))
    return millimetres(x), millimetres(y)


def _main_floor(cells: Cells) -> Cells:
    """The biggest piece of the room's cells, joined diagonally too."""
    rows, cols = cells
    top, left = int(rows.min()), int(cols.min())
    drawn = np.zeros((int(rows.max()) - top + 1, int(cols.max()) - left + 1), np.uint8)
    drawn[rows - top, cols - left] = 1
    count, pieces = cv2.connectedComponents(drawn, connectivity=8)
    if count <= 2:
        return cells
    piece = pieces[rows - top, cols - left]
    biggest = int(np.argmax(np.bincount(piece)[1:])) + 1
    return rows[piece == biggest], cols[piece == biggest]


def scan_plan(segmentation: Segmentation, source: Path, name: str) -> MadePlan:
    """The floor plan of the rooms found, ready for plan_writing.write_floorplan to check
    and write with its grid: room points and doors, no outlines, so that the simulator
    takes its walls from the grid (floorplans/README.md, "Plans without outlines"). The
    grid is the segmentation's, drawn, when it is not the map's as it is (`drawn`);
    else the map's image is to be copied."""
    plan = {
        "name": name,
        "rooms": {room.id: {"at": list(room.at)} for room in segmentation.rooms},
        "doors": [
            {
                "between": list(door.between),
                "at": list(door.at),
                "width": door.width,
                "id": door.id,
            }
            for door in segmentation.doors
        ],
        "start": segmentation.start,
    }
    header = (
        f"# Rooms found in {source.name} by `giraff-console floorplan rooms`: named by the\n"
        "# marks given, the rest room-1, room-2, ... as a page is read, from the top left.\n"
        "# Rename them as you like.\n"
    )
    drawn = segmentation.grid if segmentation.redrawn else None
    return MadePlan(source, plan, list(segmentation.notes), header, drawn)
