"""Which cuts between the rooms a segmentation found are doors, as a person would say
(issue 29): the others join their two rooms into one.

The distance segmentation (room_segmentation.py) cuts wherever the free space narrows
enough: at doorways, but also across an open hall where it bends, at the mouth of an
alcove, between a kitchen and its dining area, across a corridor between its alcoves.
A person calls an opening a door when it is no wider than a door: a double door is 1.2
to 1.4 m (`MAX_DOOR_M`), and a wider opening (an archway, an alcove, the arms of an
open hall) is a way within one room. And a door is an opening in a wall: past a cut
wider than a single door (`SINGLE_DOOR_M`) the wall must run on in line with it, as
it does past a double door's jambs and not past a corridor's walls.
"""

from __future__ import annotations

import numpy as np

MAX_DOOR_M = 1.4
# A cut wider than this is a door only if a wall runs on in line with it past a jamb
# for JAMB_M: a corridor 1.5 m wide, narrowed by a box or a ragged face, is cut as
# narrow as a double door, but across, between the corridor's own walls.
SINGLE_DOOR_M = 1.1
JAMB_M = 0.75
_GAP = 3  # cells of floor between a cut's end and its jamb, where a scan left them
_OFF = 3  # cells either side of a cut's line its wall may lie


def join_openings(labels: np.ndarray, clearance: np.ndarray, wall: np.ndarray,
                  resolution: float) -> np.ndarray:  # fmt: skip
    """For each label of `labels`, the label of the room it is part of: each two that
    meet across more than MAX_DOOR_M, or across more than SINGLE_DOOR_M with no `wall`
    (a grid of the walls' cells) in line past the cut, made one. The width across a
    border is measured from its widest point's `clearance` (metres to the nearest cell
    off the floor, either way, less the cell itself)."""
    rows, cols = labels.shape
    pairs: list[np.ndarray] = []
    widths: list[np.ndarray] = []
    places: list[np.ndarray] = []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        # Each cell against its neighbour to the right, below, and diagonally below.
        left, right = max(0, -dc), max(0, dc)
        here, there = labels[: rows - dr, left : cols - right], labels[dr:, right : cols - left]
        on = (here > 0) & (there > 0) & (here != there)
        a, b = here[on], there[on]
        pairs.append(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1))
        near = np.minimum(clearance[: rows - dr, left : cols - right][on],
                          clearance[dr:, right : cols - left][on])  # fmt: skip
        widths.append(2 * near - resolution)
        r, c = np.nonzero(on)
        places.append(np.stack([r, c + left], axis=1))
    pair, width, place = np.concatenate(pairs), np.concatenate(widths), np.concatenate(places)
    keys, which = np.unique(pair, axis=0, return_inverse=True)
    which = which.ravel()
    widest = np.zeros(len(keys))
    np.maximum.at(widest, which, width)
    reach = round(JAMB_M / resolution)
    root = np.arange(int(labels.max()) + 1)
    for key, (a, b) in enumerate(keys.tolist()):
        if widest[key] <= SINGLE_DOOR_M or (
            widest[key] <= MAX_DOOR_M and _in_a_wall(place[which == key], wall, reach)
        ):
            continue
        ra, rb = _find(root, a), _find(root, b)
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    return np.array([_find(root, label) for label in range(len(root))], dtype=labels.dtype)


def _in_a_wall(border: np.ndarray, wall: np.ndarray, reach: int) -> bool:
    """Whether the cut along `border` (cells, row and column) has `wall` in line with it
    for `reach` cells past one of its ends. The cut may lie along a doorway's mouth, off
    a ragged wall's face: a wall within _OFF cells either side of the line counts."""
    if len(border) < 2:
        return True
    middle = border.mean(axis=0)
    _, _, axes = np.linalg.svd(border - middle, full_matrices=False)
    along, across = axes[0], np.array([-axes[0][1], axes[0][0]])
    ends = (border - middle) @ along
    rows, cols = wall.shape
    offsets = np.arange(-_OFF, _OFF + 1)[:, None] * across
    for sign, end in ((-1.0, float(ends.min())), (1.0, float(ends.max()))):
        run = 0
        for step in range(1, reach + _GAP + 1):
            r, c = np.round(middle + (end + sign * step) * along + offsets).astype(int).T
            inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
            if not inside.any():
                break
            if wall[r[inside], c[inside]].any():
                run += 1
                if run >= reach:
                    return True
            elif run or step > _GAP:
                break
    return False


def _find(root: np.ndarray, label: int) -> int:
    while root[label] != label:
        root[label] = root[root[label]]
        label = int(root[label])
    return label
