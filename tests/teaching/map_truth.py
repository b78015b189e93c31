"""How a map the robot built falls on the building it was built in: for each occupied
cell, how far the truth's nearest wall or furniture is (the tests and the bench judge
a taught map by it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from giraff_console.planning.grid import OCCUPIED, OccupancyGrid


@dataclass(frozen=True)
class MapTruth:
    occupied: int  # the map's occupied cells
    inside: float  # the share of them on the truth's grid
    within_5cm: float  # the share of those within 0.05 m of the truth's occupied cells
    within_10cm: float


def map_truth(mapped: OccupancyGrid, truth: OccupancyGrid) -> MapTruth:
    near = ndimage.distance_transform_edt(truth.cells != OCCUPIED) * truth.resolution
    rows, cols = np.nonzero(mapped.cells == OCCUPIED)
    xs = mapped.origin[0] + (cols + 0.5) * mapped.resolution
    ys = mapped.origin[1] + (mapped.shape[0] - rows - 0.5) * mapped.resolution
    t_rows = truth.shape[0] - 1 - np.floor((ys - truth.origin[1]) / truth.resolution).astype(int)
    t_cols = np.floor((xs - truth.origin[0]) / truth.resolution).astype(int)
    inside = (t_rows >= 0) & (t_rows < truth.shape[0]) & (t_cols >= 0) & (t_cols < truth.shape[1])
    off = near[t_rows[inside], t_cols[inside]]
    if not len(off):
        return MapTruth(len(rows), 0.0, 0.0, 0.0)
    return MapTruth(len(rows), float(inside.mean()), float((off <= 0.05).mean()),
                    float((off <= 0.10).mean()))  # fmt: skip
