"""Rooms and doors found in a scanned map: a SLAM grid becomes a floor plan (issue 16).

A building mapped by a robot has a map_server grid but no floor plan: nobody has said
where the rooms are. The room-segmentation packages (ipa_room_segmentation's distance
segmentation, and watershed segmentations like it) find them from the distance
transform of the free space: how far each free cell is from the nearest wall. Rooms are
wide and the doorways between them narrow, so as the transform is cut at rising
heights the free space falls apart into pieces at the doorways, one piece to a room.

Here the cut rises one cell at a time, from the robot's radius (narrower space is no
room for it) upwards. Where a piece splits into two, each is a room of its own only if
it rises well clear of the split (`PROMINENCE_M`) and the split is narrow next to it
(`SADDLE_RATIO`): a doorway between rooms is, a gap between an armchair and a bed is
not. Each room's piece, taken where it split off, seeds a watershed flood of the
transform that grows it back over the whole free space, so that neighbouring rooms meet
at the narrowest cross-section between them: the doorway. Rooms too small to be rooms
(`MIN_ROOM_M2`) are flooded by their neighbours instead.

Unknown space is not free: the robot has not seen it. Holes in the free space smaller
than `SPECK_M2` are noise, or the legs of tables and chairs, and are filled before the
transform is taken, so that they neither split a room nor make one; the room points and
doorway widths are measured on the grid as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import Door, GridSpec, Point
from giraff_console.planning.grid import FREE, OccupancyGrid
from giraff_console.planning.plan_writing import MadePlan, millimetres
from giraff_console.planning.ros_map import read_grid_image, read_ros_map
from giraff_console.planning.route_planner import ROBOT_RADIUS_M
from giraff_console.planning.walls import grid_jambs

# Less floor than this is a cupboard, a bay window or noise, not a room to send a robot to.
MIN_ROOM_M2 = 1.0
# Holes in the free space up to this size are filled before segmenting: single cells a
# scan got wrong, and the legs of tables and chairs (a 7 cm leg is 0.005 m^2).
SPECK_M2 = 0.05
# A piece of free space that splits off is a room when its widest point is at least this
# much wider (in clearance, metres) than the split, and the split at most this fraction
# of it. A 0.9 m doorway (0.45 m clearance) off a 2 m corridor (1 m) is 0.55 m and 0.45;
# furniture leaves bays with a split 0.1 to 0.2 m and 0.8 or more below their middle.
PROMINENCE_M = 0.15
SADDLE_RATIO = 0.7
# Rooms whose centres lie within this of each other, top to bottom, are in one row when
# they are named in reading order.
ROW_GAP_M = 1.0
_CONNECTED = np.ones((3, 3), dtype=bool)  # eight neighbours: a room is one piece diagonally too


class SegmentationError(ValueError):
    """A map with nothing to segment; the message says why, in one line."""


@dataclass(frozen=True)
class FoundRoom:
    id: str
    at: Point  # the point furthest from any wall: where the robot stands best
    label: int  # its cells' value in Segmentation.labels
    area_m2: float


@dataclass(frozen=True)
class Segmentation:
    grid: OccupancyGrid
    labels: np.ndarray  # int32 per cell: a room's label, 0 for no room
    rooms: tuple[FoundRoom, ...]  # in reading order: room-1 top left
    doors: tuple[Door, ...]
    start: str  # the room with the most doors, where the robot is best placed to start
    notes: tuple[str, ...]  # what was left out, for the operator to know


def read_scan(path: str | Path) -> tuple[GridSpec, OccupancyGrid]:
    """The ROS map_server map at `path` and its grid; FloorPlanError for a bad map."""
    spec = read_ros_map(path)
    pixels = read_grid_image(spec.image)
    grid = OccupancyGrid.from_image(pixels, spec.resolution, spec.origin[:2], spec.negate,
                                    spec.occupied_thresh, spec.free_thresh)  # fmt: skip
    return spec, grid


def segment_rooms(grid: OccupancyGrid, robot_radius: float = ROBOT_RADIUS_M,
                  min_area: float = MIN_ROOM_M2) -> Segmentation:  # fmt: skip
    """The rooms of `grid` and the doors between them; SegmentationError if none."""
    free = grid.cells == FREE
    if not free.any():
        raise SegmentationError("no free cell in the map: nothing to segment")
    floor = _without_specks(free, round(SPECK_M2 / grid.resolution**2))
    clearance = _clearance(floor, grid.resolution)
    if clearance.max() <= robot_radius:
        raise SegmentationError(
            f"no free space wide enough for the robot ({robot_radius:g} m radius): "
            "nothing to segment"
        )
    seeds = _seeds(clearance, robot_radius, grid.resolution)
    min_cells = min_area / grid.resolution**2
    while True:
        labels = _flood(clearance, floor, seeds, grid.resolution)
        areas = np.bincount(labels.ravel(), minlength=seeds.max() + 1)
        small = [label for label in range(1, len(areas)) if 0 < areas[label] < min_cells]
        if not small:
            break
        seeds[np.isin(seeds, small)] = 0
    if not labels.any():
        raise SegmentationError(
            f"no room of {min_area:g} m² or more that the robot ({robot_radius:g} m radius) "
            "fits in: nothing to segment"
        )
    real = _clearance(free, grid.resolution)
    return _plan(grid, labels, real, robot_radius)


def _without_specks(free: np.ndarray, speck_cells: int) -> np.ndarray:
    """`free` with its small holes filled: blobs of other cells with free all round."""
    _, blobs, stats, _ = cv2.connectedComponentsWithStats((~free).astype(np.uint8), connectivity=8)
    rows, cols = free.shape
    left, top = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    right = left + stats[:, cv2.CC_STAT_WIDTH]
    bottom = top + stats[:, cv2.CC_STAT_HEIGHT]
    inside = (left > 0) & (top > 0) & (right < cols) & (bottom < rows)
    specks = inside & (stats[:, cv2.CC_STAT_AREA] <= speck_cells)
    specks[0] = False  # label 0 is the free space itself
    return free | specks[blobs]


def _clearance(free: np.ndarray, resolution: float) -> np.ndarray:
    """Metres from each free cell's centre to the nearest other cell's centre (0 off the
    free space); the map's edge counts as a wall."""
    padded = np.pad(free.astype(np.uint8), 1)
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return distance[1:-1, 1:-1].astype(np.float64) * resolution


def _seeds(clearance: np.ndarray, robot_radius: float, step: float) -> np.ndarray:
    """One seed per room, numbered from 1: the piece of the cut through the clearance
    where it split off from its neighbours, or, for a piece that never splits, the whole
    of it at the robot's radius.

    The cut falls one cell at a time from the top. Each piece at one height holds the
    pieces of the height above it; where it holds several, those rising far enough above
    it (`_stands_out`) are rooms of their own, along with the highest, and each is seeded
    with what it was just above the split. A piece that has split already has its rooms
    seeded, and the rest are bumps of the highest: they join it."""
    seeds = np.zeros(clearance.shape, dtype=np.int32)
    heights = np.arange(robot_radius, clearance.max(), step)
    above: np.ndarray | None = None  # the pieces at the last height, and for each:
    above_peaks: list[tuple[float, tuple[int, int]]] = []  # its highest clearance and cell
    above_split: list[bool] = []  # whether it holds several rooms
    for height in heights[::-1]:
        count, pieces = cv2.connectedComponents((clearance > height).astype(np.uint8),
                                                connectivity=8, ltype=cv2.CV_32S)  # fmt: skip
        peaks = _peaks(clearance, pieces, count)
        holds: dict[int, list[int]] = {}
        for piece, (_, cell) in enumerate(above_peaks, start=1):
            holds.setdefault(int(pieces[cell]), []).append(piece)
        split = [False] * count
        for piece in range(1, count):
            inner = sorted(holds.get(piece, []), key=lambda p: -above_peaks[p - 1][0])
            rooms = inner[:1] + [p for p in inner[1:] if _stands_out(above_peaks[p - 1][0], height)]
            if len(rooms) > 1:
                split[piece] = True
                for room in rooms:
                    if not above_split[room - 1]:
                        assert above is not None
                        seeds[(above == room) & (seeds == 0)] = seeds.max() + 1
            elif inner:
                split[piece] = above_split[inner[0] - 1]
        above, above_peaks, above_split = pieces, peaks, split[1:]
    if above is not None:
        for piece, was_split in enumerate(above_split, start=1):
            if not was_split:
                seeds[above == piece] = seeds.max() + 1
    return seeds


def _peaks(clearance: np.ndarray, pieces: np.ndarray,
           count: int) -> list[tuple[float, tuple[int, int]]]:  # fmt: skip
    """Each piece's highest clearance and a cell where it is that high, pieces 1 on."""
    rows, cols = np.nonzero(pieces)
    piece, height = pieces[rows, cols], clearance[rows, cols]
    tops = np.zeros(count)
    np.maximum.at(tops, piece, height)
    top = height == tops[piece]
    _, first = np.unique(piece[top], return_index=True)
    rows, cols = rows[top][first], cols[top][first]
    return [(float(tops[i + 1]), (int(rows[i]), int(cols[i]))) for i in range(count - 1)]


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
    for height in np.arange(clearance.max(), -step, -step):
        open_ = floor & (clearance >= height)
        while True:
            reached = cv2.dilate(labels, _CONNECTED.astype(np.uint8))
            new = open_ & (labels == 0) & (reached > 0)
            if not new.any():
                break
            labels[new] = reached[new]
    return labels.astype(np.int32)


def _plan(grid: OccupancyGrid, labels: np.ndarray, clearance: np.ndarray,
          robot_radius: float) -> Segmentation:  # fmt: skip
    """Name the rooms, put a door in every doorway between two of them that the robot
    fits through, and leave out the rooms it could not reach from the rest."""
    cells = _cells_of(labels)
    # A doorway no wider than the robot is none: no plan could take it through.
    between = [(a, b, at, width) for a, b, at, width in _doorways(grid, labels, clearance)
               if width > 2 * robot_radius]  # fmt: skip
    joined = _reachable(cells, [(a, b) for a, b, _, _ in between])
    notes = []
    if len(joined) < len(cells):
        left_out = [label for label in cells if label not in joined]
        # The biggest few, for a note the operator reads rather than a list of specks.
        biggest = sorted(left_out, key=lambda label: -len(cells[label][0]))[:3]
        where = ", ".join(f"({x:.1f}, {y:.1f})" for x, y in
                          (_at(grid, cells[label], clearance) for label in biggest))  # fmt: skip
        more = f" and {len(left_out) - 3} more" if len(left_out) > 3 else ""
        notes.append(f"left out {len(left_out)} piece{'s' if len(left_out) > 1 else ''} of "
                     f"floor the robot cannot reach from the rest, at {where}{more}")  # fmt: skip
        labels = np.where(np.isin(labels, left_out), 0, labels)
    order = _reading_order(grid, {label: cells[label] for label in joined})
    names = {label: f"room-{number}" for number, label in enumerate(order, start=1)}
    area = grid.resolution**2
    rooms = tuple(
        FoundRoom(
            names[label], _at(grid, cells[label], clearance), label, len(cells[label][0]) * area
        )
        for label in order
    )
    rank = {label: number for number, label in enumerate(order)}
    kept: list[tuple[int, int, Point, float]] = []
    for a, b, at, width in between:
        if a in rank and b in rank:
            first, second = sorted((a, b), key=rank.__getitem__)
            kept.append((first, second, at, width))
    kept.sort(key=lambda door: (rank[door[0]], rank[door[1]], door[2][0], -door[2][1]))
    doors: list[Door] = []
    for a, b, at, width in kept:
        door_id = f"{names[a]}-{names[b]}"
        # A second doorway between the same two rooms: room-7-room-10-2.
        alike = sum(door.between == (names[a], names[b]) for door in doors)
        door_id += f"-{alike + 1}" if alike else ""
        doors.append(Door(door_id, (names[a], names[b]), at, width, True))
    count = {room.id: sum(room.id in door.between for door in doors) for room in rooms}
    start = max(rooms, key=lambda room: count[room.id]).id
    return Segmentation(grid, labels, rooms, tuple(doors), start, tuple(notes))


Cells = tuple[np.ndarray, np.ndarray]  # rows and columns


def _cells_of(labels: np.ndarray) -> dict[int, Cells]:
    """Each room's cells, by label, found in one pass over the grid."""
    rows, cols = np.nonzero(labels)
    ids = labels[rows, cols]
    order = np.argsort(ids, kind="stable")
    ids, rows, cols = ids[order], rows[order], cols[order]
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]]) if len(ids) else np.array([], int)
    ends = np.r_[starts[1:], len(ids)]
    return {int(ids[s]): (rows[s:e], cols[s:e]) for s, e in zip(starts, ends, strict=True)}


def _doorways(grid: OccupancyGrid, labels: np.ndarray,
              clearance: np.ndarray) -> list[tuple[int, int, Point, float]]:  # fmt: skip
    """Where each two rooms meet: (one's label, the other's, the doorway's centre and
    width), once for each separate stretch of their border, so that a room with two
    doorways onto a corridor has two doors. The doorway is measured from the widest
    point of the stretch, which the flood put where the way is narrowest."""
    rows, cols = labels.shape
    border: dict[tuple[int, int], list[Cells]] = {}
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        # Each cell against its neighbour to the right, below, and diagonally below.
        left, right = max(0, -dc), max(0, dc)
        here = labels[: rows - dr, left : cols - right]
        there = labels[dr:, right : cols - left]
        r, c = np.nonzero((here > 0) & (there > 0) & (here != there))
        low = np.minimum(here[r, c], there[r, c])
        high = np.maximum(here[r, c], there[r, c])
        for key in set(zip(low.tolist(), high.tolist(), strict=True)):
            pick = (low == key[0]) & (high == key[1])
            border.setdefault(key, []).append((r[pick], c[pick] + left))
            border[key].append((r[pick] + dr, c[pick] + right))
    found: list[tuple[int, int, Point, float]] = []
    for (a, b), pieces in border.items():
        # The border drawn in its own box, to be cut into its separate stretches.
        r = np.concatenate([piece[0] for piece in pieces])
        c = np.concatenate([piece[1] for piece in pieces])
        top, left = r.min(), c.min()
        drawn = np.zeros((r.max() - top + 1, c.max() - left + 1), dtype=np.uint8)
        drawn[r - top, c - left] = 1
        count, stretches = cv2.connectedComponents(drawn, connectivity=8)
        for stretch in range(1, count):
            on = np.argwhere(stretches == stretch) + np.array([top, left])
            best = on[int(np.argmax(clearance[on[:, 0], on[:, 1]]))]
            found.append((a, b, *_doorway(grid, clearance, (int(best[0]), int(best[1])))))
    return found


def _reachable(cells: dict[int, Cells], doors: list[tuple[int, int]]) -> set[int]:
    """The rooms joined by doors to the most others (the most floor, if several groups
    are as many): a plan must reach every room from its start."""
    group = {label: {label} for label in cells}
    for a, b in doors:
        if group[a] is not group[b]:
            merged = group[a] | group[b]
            for label in merged:
                group[label] = merged
    groups = {id(rooms): rooms for rooms in group.values()}.values()
    return max(groups, key=lambda rooms: (len(rooms), sum(len(cells[r][0]) for r in rooms)))


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
    half a cell), the one nearest the room's middle."""
    rows, cols = cells
    room = clearance[rows, cols]
    best = room >= room.max() - grid.resolution / 2
    rows, cols = rows[best], cols[best]
    middle = np.hypot(rows - rows.mean(), cols - cols.mean())
    i = int(np.argmin(middle))
    x, y = grid.centre_of(int(rows[i]), int(cols[i]))
    return millimetres(x), millimetres(y)


def _doorway(
    grid: OccupancyGrid, clearance: np.ndarray, cell: tuple[int, int]
) -> tuple[Point, float]:
    """The centre and free width of the doorway whose widest point on the border between
    two rooms is `cell`: half-way between its jambs, the occupied cells either side (as
    the route planner finds them, walls.py), and the space between their faces."""
    x, y = grid.centre_of(*cell)
    guess = Door("", ("", ""), (x, y), 2 * float(clearance[cell]), True)
    jambs = grid_jambs(grid, guess)
    if jambs is None:
        return (millimetres(x), millimetres(y)), millimetres(guess.width)
    (ax, ay), (bx, by) = jambs
    middle = ((ax + bx) / 2, (ay + by) / 2)
    width = math.dist(jambs[0], jambs[1]) - grid.resolution  # centres to faces
    row, col = grid.cell_of(*middle)
    if grid.cells[row, col] != FREE:
        middle = (x, y)
    return (millimetres(middle[0]), millimetres(middle[1])), millimetres(width)


def scan_plan(segmentation: Segmentation, source: Path, name: str) -> MadePlan:
    """The floor plan of the rooms found, ready for plan_writing.write_floorplan to check
    and write with the map as its grid: room points and doors, no outlines, so that the
    simulator takes its walls from the grid (floorplans/README.md, "Plans without
    outlines")."""
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
        f"# Rooms found in {source.name} by `giraff-console floorplan rooms`: named room-1,\n"
        "# room-2, ... as a page is read, from the top left. Rename them as you like.\n"
    )
    return MadePlan(source, plan, list(segmentation.notes), header)
