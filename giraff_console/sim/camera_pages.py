"""A marker's printed page as the synthetic camera's sensor sees it (sim/camera.py).

A real sensor integrates the light over each pixel; the page is supersampled likewise,
so that its edges fall between pixels where they should and a pose from its corners is
as good as the pixels allow (issue 14).
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from giraff_console.sim.world import QUIET_ZONE_CELLS, WorldMarker

# A marker's page in grey: its ink and its paper (PALETTE's MARKER_PAGE is a placeholder).
INK, PAPER = 25.0, 240.0
# Fine samples per cell side, 2 to MAX_FINE per pixel side: small cells get the most, so that
# an edge lands within a few hundredths of a pixel of where it should.
FINE_SAMPLES_PER_CELL = 32
MAX_FINE = 16


def page_shades(
    marker: WorldMarker, camera: np.ndarray, heading: float, rows: np.ndarray,
    cols: np.ndarray, intrinsics: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The grey level of each of a marker's pixels (`rows`, `cols` of the picture), seen
    from a level camera at `camera` (x, y, height) looking along `heading`, whose
    pinhole matrix is `intrinsics`: the page warped into the picture k times finer than
    its pixels, then averaged over each pixel, as a sensor would.

    The page is a plane, so the picture of it is a homography of its cells; OpenCV
    warps them, each fine sample taking the cell it falls in."""
    top, left = rows.min(), cols.min()
    height, width = rows.max() - top + 1, cols.max() - left + 1
    centre = np.array([marker.x, marker.y, marker.height])
    facing = marker.facing
    right = np.array([-math.sin(facing), math.cos(facing), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    ahead = np.array([math.cos(heading), math.sin(heading), 0.0])
    # The camera's axes in the world: x to the right, y down, z ahead.
    axes = np.array([[ahead[1], -ahead[0], 0.0], [0.0, 0.0, -1.0], ahead])
    # Page metres (across to the right, up) to picture pixels.
    page_to_camera = np.column_stack([axes @ right, axes @ up, axes @ (centre - camera)])
    page_to_picture = intrinsics @ page_to_camera
    # Cells to sample: cell (i, j)'s centre at whole numbers, as OpenCV's remaps take
    # them; the page's quiet zone around the pattern.
    half, cell = marker.outer / 2, marker.cell
    cells_to_page = np.array([[cell, 0.0, cell / 2 - half], [0.0, -cell, half - cell / 2],
                              [0.0, 0.0, 1.0]])  # fmt: skip
    # How many pixels a cell spans at the page's centre: the finer, the fewer samples.
    seen_from = camera - centre
    gap = float(seen_from[:2] @ [math.cos(facing), math.sin(facing)])
    cell_pixels = intrinsics[0, 0] * cell * gap / max(float(seen_from @ seen_from), 1e-6)
    k = min(max(math.ceil(FINE_SAMPLES_PER_CELL / max(cell_pixels, 1e-3)), 2), MAX_FINE)
    # Fine sample (i, j) of the box at pixel (left + (i + 0.5) / k - 0.5, ...).
    fine_to_picture = np.array(
        [[1 / k, 0.0, left + 0.5 / k - 0.5], [0.0, 1 / k, top + 0.5 / k - 0.5], [0, 0, 1.0]]
    )
    try:
        fine_to_cells = np.linalg.inv(page_to_picture @ cells_to_page) @ fine_to_picture
    except np.linalg.LinAlgError:  # seen exactly edge-on: no page to see
        return np.full(len(rows), PAPER, dtype=np.uint8)
    fine = cv2.warpPerspective(
        _printed(marker), fine_to_cells, (width * k, height * k),
        flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT, borderValue=PAPER,
    )  # fmt: skip
    box = cv2.resize(fine, (width, height), interpolation=cv2.INTER_AREA)
    return np.round(box[rows - top, cols - left]).astype(np.uint8)


@functools.lru_cache(maxsize=1024)
def _printed(marker: WorldMarker) -> np.ndarray:
    """A marker's page, a grey level a cell, its quiet zone round it: made once a marker
    (a building has a few hundred), as every frame that shows it warps it."""
    paper = np.pad(marker.pattern, QUIET_ZONE_CELLS, constant_values=True)
    shade = np.where(paper, np.float32(PAPER), np.float32(INK))
    shade.setflags(write=False)
    return shade
