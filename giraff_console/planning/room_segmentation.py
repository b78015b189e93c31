"""Rooms and doors found in a scanned map: a SLAM grid becomes a floor plan (issue 16).

A building mapped by a robot has a map_server grid but no floor plan: nobody has said
where the rooms are. The room-segmentation packages (ipa_room_segmentation's distance
segmentation, and watershed segmentations like it) find them from the distance
transform of the free space: how far each free cell is from the nearest wall. Rooms are
wide and the doorways between them narrow, so as the transform is cut at rising
heights the free space falls apart into pieces at the doorways, one piece to a room.

The rooms are found on the grid the plan will use: the map cropped to its floor and
cleared of specks (scan_grid.py), with unknown space not free, since the robot has not
seen it. Here the cut rises one cell at a time, from the least clearance the route
planner leaves the robot (its radius and CLEARANCE_M; narrower space is no room for it)
upwards. Where a piece splits into two, each is a room of its own only if it rises well
clear of the split (`PROMINENCE_M`) and the split is narrow next to it
(`SADDLE_RATIO`): a doorway between rooms is, a gap between an armchair and a bed is
not. Each room's piece, taken where it split off, seeds a watershed flood of the
transform that grows it back over the whole free space, so that neighbouring rooms meet
at the narrowest cross-section between them: the doorway (room_doors.py). Rooms too
small to be rooms (`MIN_ROOM_M2`) are flooded by their neighbours instead, and rooms the
planner cannot take the robot to from the rest are left out.
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
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M
from giraff_console.planning.scan_grid import CROP_MARGIN_M, SPECK_M2, SPECK_SIDE_M, clean_grid

# A piece of free space that splits off is a room when its widest point is at least this
# much wider (in clearance, metres) than the split, and the split at most this fraction
# of it. A 0.9 m doorway (0.45 m clearance) off a 2 m corridor (1 m) is 0.55 m and 0.45;
# furniture leaves bays with a split 0.1 to 0.2 m and 0.8 or more below their middle.
PROMINENCE_M = 0.15
SADDLE_RATIO = 0.7
# Rooms whose centres lie within this of each other, top to bottom, are in one row when
# they are named in reading order.
ROW_GAP_M = 1.0
# The cut rises a cell at a time up to this clearance, and by a twentieth of its height
# above: a split higher up is an opening far wider than any door (room_openings.py),
# which joins its two rooms whatever height it is found at, and an open hall 150 m wide
# would take 1500 cuts of a cell (156 s for a 300 x 150 m hall).
FINE_M = 1.5
COARSE_RATIO = 1.05
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
    seeds = _seeds(built_clearance, least, grid.resolution)
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


def _seeds(clearance: np.ndarray, least: float, step: float) -> np.ndarray:
    """One seed per room, numbered from 1: the piece of the cut through the clearance
    where it split off from its neighbours, or, for a piece that never splits, the whole
    of it at the least clearance the robot needs (`least`).

    The cut falls one cell at a time from the top. Each piece at one height holds the
    pieces of the height above it; where it holds several, those rising far enough above
    it (`_stands_out`) are rooms of their own, along with the highest, and each is seeded
    with what it was just above the split. A piece that has split already has its rooms
    seeded, and the rest are bumps of the highest: they join it."""
    seeds = np.zeros(clearance.shape, dtype=np.int32)
    heights = _heights(least, float(clearance.max()), step)
    above: np.ndarray | None = None  # the pieces at the last height, and for each:
    above_peaks: list[tuple[float, tuple[int, int]]] = []  # its highest clearance and cell
    above_split: list[bool] = []  # whether it holds several rooms
    last = math.inf
    for height in heights[::-1]:
        count, pieces = cv2.connectedComponents((clearance > height).astype(np.uint8),
                                                connectivity=8, ltype=cv2.CV_32S)  # fmt: skip
        holds: dict[int, list[int]] = {}
        for piece, (_, cell) in enumerate(above_peaks, start=1):
            holds.setdefault(int(pieces[cell]), []).append(piece)
        peaks = _peaks(clearance, pieces, count, holds, above_peaks, height, last)
        split = [False] * count
        new_rooms: list[int] = []
        for piece in range(1, count):
            inner = sorted(holds.get(piece, []), key=lambda p: -above_peaks[p - 1][0])
            rooms = inner[:1] + [p for p in inner[1:] if _stands_out(above_peaks[p - 1][0], height)]
            if len(rooms) > 1:
                split[piece] = True
                new_rooms += [room for room in rooms if not above_split[room - 1]]
            elif inner:
                split[piece] = above_split[inner[0] - 1]
        if new_rooms:
            assert above is not None
            _seed(seeds, above, new_rooms)
        above, above_peaks, above_split, last = pieces, peaks, split[1:], height
    if above is not None:
        _seed(seeds, above, [piece for piece, was in enumerate(above_split, start=1) if not was])
    return seeds


def _heights(low: float, high: float, step: float) -> np.ndarray:
    """The heights from `low` up to, not including, `high`: every `step` up to FINE_M,
    then each COARSE_RATIO times the last."""
    fine = np.arange(low, min(high, FINE_M), step)
    coarse = [FINE_M] if high > FINE_M else []
    while coarse and coarse[-1] * COARSE_RATIO < high:
        coarse.append(coarse[-1] * COARSE_RATIO)
    return np.concatenate([fine, np.array(coarse)])


def _seed(seeds: np.ndarray, pieces: np.ndarray, rooms: list[int]) -> None:
    """Seed each of `rooms` (pieces of `pieces`) where no seed is yet, numbered on from
    the seeds there are: one pass over the grid for them all."""
    if not rooms:
        return
    number = np.zeros(int(pieces.max()) + 1, dtype=np.int32)
    number[rooms] = np.arange(1, len(rooms) + 1) + seeds.max()
    new = number[pieces]
    free = (seeds == 0) & (new > 0)
    seeds[free] = new[free]


def _peaks(clearance: np.ndarray, pieces: np.ndarray, count: int, holds: dict[int, list[int]],
           above_peaks: list[tuple[float, tuple[int, int]]], height: float,
           last: float) -> list[tuple[float, tuple[int, int]]]:  # fmt: skip
    """Each piece's highest clearance and a cell where it is that high, pieces 1 on: the
    highest of the pieces above it that it holds, or, for a piece new at this height,
    found among the cells that rose above the cut since the `last` (one pass over them
    only, not the whole grid)."""
    peaks: list[tuple[float, tuple[int, int]] | None] = [None] * (count - 1)
    for holder, inner in holds.items():
        peaks[holder - 1] = max((above_peaks[p - 1] for p in inner), key=lambda peak: peak[0])
    if any(peak is None for peak in peaks):
        rows, cols = np.nonzero((clearance > height) & (clearance <= last))
        piece, rise = pieces[rows, cols], clearance[rows, cols]
        order = np.lexsort((-rise, piece))  # each piece's highest cell first
        piece, first = np.unique(piece[order], return_index=True)
        for p, i in zip(piece.tolist(), order[first].tolist(), strict=True):
            if peaks[p - 1] is None:
                peaks[p - 1] = (float(rise[i]), (int(rows[i]), int(cols[i])))
    assert all(peak is not None for peak in peaks)
    return peaks  # type: ignore[return-value]


def _stands_out(peak: float, split: float) -> bool:
    """Whether a piece whose clearance rises to `peak` is a room apart from the piece it
    meets at `split`, rather than a bay of it."""
    return peak - split >= PROMINENCE_M and split <= SADDLE_RATIO * peak


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
    coarse = _heights(FINE_M, top, step)[::-1] if top > FINE_M else np.array([])
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
