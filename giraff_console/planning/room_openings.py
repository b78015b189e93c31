"""Which cuts between the rooms a segmentation found are doors, as a person would say
(issue 29): the others join their two rooms into one.

The distance segmentation (room_segmentation.py) cuts wherever the free space narrows
enough: at doorways, but also across an open hall where it bends, at the mouth of an
alcove, between a kitchen and its dining area. A person calls an opening a door when it
is no wider than a door: a double door is 1.2 to 1.4 m (`MAX_DOOR_M`), and a wider
opening (an archway, an alcove, the arms of an open hall) is a way within one room.
"""

from __future__ import annotations

import numpy as np

MAX_DOOR_M = 1.4


def join_openings(labels: np.ndarray, clearance: np.ndarray, resolution: float) -> np.ndarray:
    """For each label of `labels`, the label of the room it is part of: each two that
    meet across more than MAX_DOOR_M made one. The width across a border is measured
    from its widest point's `clearance` (metres to the nearest cell off the floor,
    either way, less the cell itself)."""
    rows, cols = labels.shape
    pairs: list[np.ndarray] = []
    widths: list[np.ndarray] = []
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
    pair, width = np.concatenate(pairs), np.concatenate(widths)
    root = np.arange(int(labels.max()) + 1)
    for a, b in np.unique(pair[width > MAX_DOOR_M], axis=0).tolist():
        ra, rb = _find(root, a), _find(root, b)
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    return np.array([_find(root, label) for label in range(len(root))], dtype=labels.dtype)


def _find(root: np.ndarray, label: int) -> int:
    while root[label] != label:
        root[label] = root[root[label]]
        label = int(root[label])
    return label
