"""The floor as built: a scan's free space with the furniture standing on it taken away,
for the rooms to be found on (room_segmentation.py, issue 29).

A laser at knee height sees a bed, a wardrobe, a counter or a wheelchair parked in a
corridor as it sees a wall, and the rooms found on its free space alone come out as a
person would not see them: a corridor split at the wheelchair, a utility room at its
washing machines, the floor between a bed and a wardrobe left in no room (Bormann et
al.'s benchmark, ICRA 2016: 779 segments for 557 rooms with furniture). A person tells
furniture from walls by its shape, and so does this: a wall as scanned is thin, a face
or two of cells (0.15 m, a cell more where its face is ragged), and furniture is a
blob, as deep as it is long. So occupied cells in a square `FURNITURE_SIDE_M` across
(a morphological opening) are furniture: a bed, a kitchen island, a sofa, and a pillar
too, which makes no room either. A stub of wall standing free between doorways is
thin, and stays. Unknown cells are never taken for
furniture: they are what the robot has not seen. The furniture's cells are floor to the
segmentation only; the plan's grid, and the route planner, keep them as scanned.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid

# Occupied cells in a square this wide are furniture: a wall scanned from both sides is
# at most 0.25 m (0.15 m, and a cell of ragged face either side); a bedside table 0.45 m.
FURNITURE_SIDE_M = 0.4
# A blob against a wall takes the wall behind it into its square: this much of it, next
# to the floor on the wall's far side, is kept as wall (0.15 m and a ragged cell).
SEAL_M = 0.25


def floor_as_built(grid: OccupancyGrid) -> np.ndarray:
    """Whether each cell of `grid` is floor, the furniture's cells taken as floor."""
    free = grid.cells == FREE
    occupied = grid.cells == OCCUPIED
    # An odd number of cells: OpenCV's opening with an even kernel is a cell off true.
    side = 2 * math.ceil(FURNITURE_SIDE_M / grid.resolution / 2 - 1e-9) + 1
    kernel = np.ones((side, side), np.uint8)
    blobs = _sealed(cv2.morphologyEx(occupied.astype(np.uint8), cv2.MORPH_OPEN, kernel) > 0,
                    free, math.ceil(SEAL_M / grid.resolution), side)  # fmt: skip
    return free | blobs


def _sealed(blobs: np.ndarray, free: np.ndarray, seal: int, side: int) -> np.ndarray:
    """`blobs` less the cells within `seal` of floor that each blob touches apart from
    the floor round it: a wardrobe's square takes in the wall it stands against, and
    taken away whole it would open the room into the one behind.

    The floor round a blob is the biggest piece of the free cells in a ring two cells
    wide about it; any other piece of the ring as long as the blob is wide (`side`) is
    another room's, across a wall."""
    count, pieces, stats, _ = cv2.connectedComponentsWithStats(blobs.astype(np.uint8),
                                                               connectivity=8)  # fmt: skip
    kept = blobs.copy()
    pad = seal + 3
    ring_kernel = np.ones((5, 5), np.uint8)
    seal_kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * seal + 1, 2 * seal + 1))
    rows, cols = blobs.shape
    for blob in range(1, count):
        left, top, width, height = stats[blob, :4]
        r0, c0 = max(0, top - pad), max(0, left - pad)
        r1, c1 = min(rows, top + height + pad), min(cols, left + width + pad)
        inside = pieces[r0:r1, c0:c1] == blob
        ring = (cv2.dilate(inside.astype(np.uint8), ring_kernel) > 0) & ~inside & free[r0:r1, c0:c1]
        parts, part = cv2.connectedComponents(ring.astype(np.uint8), connectivity=8)
        if parts <= 2:
            continue
        sizes = np.bincount(part.ravel())
        sizes[0] = 0
        # A cell or two bitten out of a ragged face is no room: another room's floor
        # runs the length of the blob.
        across = ((sizes[part] >= side) & (part != int(np.argmax(sizes)))).astype(np.uint8)
        kept[r0:r1, c0:c1] &= ~((cv2.dilate(across, seal_kernel) > 0) & inside)
    return kept
