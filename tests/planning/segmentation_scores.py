"""Room segmentation scored against the labelled scans' truth (tests/buildings/
labelled_scans.py) with the measures of Bormann et al.'s benchmark (ICRA 2016): for each
room of the truth, the largest share of its floor one segment covers (recall, averaged
over the rooms); for each segment, the largest share of its floor inside one room of the
truth (precision, averaged over the segments).

The floor scored is the floor the scan shows free, in the truth's rooms: floor under
furniture is no floor to the scan, and a doorway between two rooms belongs to neither.
Floor the segmentation leaves unlabelled is in no segment, and so counts against the
room's recall.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from giraff_console.planning.grid import FREE
from giraff_console.planning.room_segmentation import (
    Segmentation,
    SegmentationError,
    segment_rooms,
)
from tests.buildings.labelled_scans import LabelledScan


@dataclass(frozen=True)
class Score:
    recall: float  # per cent
    precision: float
    rooms: int  # in the truth
    segments: int  # found
    seconds: float


def score(truth: np.ndarray, labels: np.ndarray, floor: np.ndarray) -> tuple[float, float]:
    """Recall and precision, per cent, of `labels` (0 for none) against `truth` on the
    cells of `floor` in a room of the truth."""
    on = floor & (truth > 0)
    rooms, segments = truth[on], labels[on]
    room_ids, rooms = np.unique(rooms, return_inverse=True)
    segment_ids, segments = np.unique(segments, return_inverse=True)
    table = np.zeros((len(room_ids), len(segment_ids)), dtype=np.int64)
    np.add.at(table, (rooms, segments), 1)
    labelled = segment_ids > 0
    recall = (table[:, labelled].max(axis=1, initial=0) / table.sum(axis=1)).mean()
    found = table[:, labelled]
    precision = (found.max(axis=0) / found.sum(axis=0)).mean() if found.size else 0.0
    return 100 * float(recall), 100 * float(precision)


def segment_and_score(scan: LabelledScan, furnished: bool) -> tuple[Score, Segmentation | None]:
    """The scan segmented (None for a SegmentationError, which labels nothing) and scored."""
    grid = scan.grid(furnished)
    started = time.perf_counter()
    try:
        found: Segmentation | None = segment_rooms(grid)
    except SegmentationError:  # no plan at all: nothing labelled
        found = None
    seconds = time.perf_counter() - started
    labels = found.labels if found else np.zeros(grid.shape, np.int32)
    recall, precision = score(scan.truth, labels, grid.cells == FREE)
    segments = len(found.rooms) if found else 0
    return Score(recall, precision, len(scan.rooms), segments, seconds), found
