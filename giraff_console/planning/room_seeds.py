"""The seeds of the rooms in a scan's floor (room_segmentation.py): one piece of floor for
each room, where it splits off from its neighbours as a cut through the clearance (how
far each cell is from the nearest wall) rises. Doorways are narrow and rooms wide, so
as the cut rises the floor falls apart at the doorways, one piece to a room; a bay
between furniture splits off too, but hardly rises above the split (`_stands_out`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

# A piece of free space that splits off is a room when its widest point is at least this
# much wider (in clearance, metres) than the split, and the split at most this fraction
# of it. A 0.9 m doorway (0.45 m clearance) off a 2 m corridor (1 m) is 0.55 m and 0.45;
# furniture leaves bays with a split 0.1 to 0.2 m and 0.8 or more below their middle.
PROMINENCE_M = 0.15
SADDLE_RATIO = 0.7
# The cut rises a cell at a time up to this clearance, and by a twentieth of its height
# above: a split higher up is an opening far wider than any door (room_openings.py),
# which joins its two rooms whatever height it is found at, and an open hall 150 m wide
# would take 1500 cuts of a cell (156 s for a 300 x 150 m hall).
FINE_M = 1.5
COARSE_RATIO = 1.05


def room_seeds(clearance: np.ndarray, least: float, step: float) -> np.ndarray:
    """One seed per room, numbered from 1: the piece of the cut through the clearance
    where it split off from its neighbours, or, for a piece that never splits, the whole
    of it at the least clearance the robot needs (`least`).

    The cut falls one cell at a time from the top. Each piece at one height holds the
    pieces of the height above it; where it holds several, those rising far enough above
    it (`_stands_out`) are rooms of their own, along with the highest, and each is seeded
    with what it was just above the split. A piece that has split already has its rooms
    seeded, and the rest are bumps of the highest: they join it."""
    seeds = np.zeros(clearance.shape, dtype=np.int32)
    cuts = heights(least, float(clearance.max()), step)
    above: np.ndarray | None = None  # the pieces at the last height, and for each:
    above_peaks: list[tuple[float, tuple[int, int]]] = []  # its highest clearance and cell
    above_split: list[bool] = []  # whether it holds several rooms
    last = math.inf
    for height in cuts[::-1]:
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


def heights(low: float, high: float, step: float) -> np.ndarray:
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
