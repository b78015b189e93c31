"""What the synthetic camera paints with: materials and their colours, and the textures
it looks its floor and walls up in (sim/camera.py).

The textures are made once and shared: the floor's tiles, two by two, repeated across
the building by the camera's warp; and a wall's strips, what a column of each kind
shows at each height, a millimetre a row. Every edge in them falls on their grid, so a
pixel looked up in them shows what its own ray meets (issue 14 asks for a camera fast
enough for 10 fps beside other work, and for a hundred thousand frames of benchmark).
"""

from __future__ import annotations

import numpy as np

from giraff_console.sim.world import POSTER_BOTTOM, POSTER_HEIGHT

WALL_HEIGHT_M = 2.5
FLOOR_TILE_M = 0.5
PANEL_M = 1.2

# Materials, and their colours in BGR as OpenCV keeps them.
CEILING, WALL_PAINT, SEAM, SKIRTING, FRAME, POSTER_DARK, POSTER_LIGHT, TILE_A, TILE_B, GROUT = (
    range(10)
)
# Obstacles: an orange box, its faces shaded by which way they face, and a door leaf a
# shade lighter than its frame so the frame still shows around it.
BOX, BOX_SIDE, BOX_LID, DOOR_LEAF = range(10, 14)
# A marker's printed page: shaded per pixel between ink and paper after the palette.
MARKER_PAGE = 14
PALETTE = np.array(
    [
        [225, 225, 220], [178, 196, 214], [110, 120, 130], [60, 70, 90], [40, 55, 85],
        [40, 30, 150], [235, 235, 235], [150, 150, 140], [120, 118, 110], [70, 70, 70],
        [30, 140, 235], [20, 105, 185], [90, 180, 250], [45, 70, 105], [240, 240, 240],
    ],
    dtype=np.uint8,
)  # fmt: skip
# The posters' chequer, across and up, metres.
POSTER_CELL_WIDTH, POSTER_CELL_HEIGHT = 0.15, 0.16
SKIRTING_M = 0.12
SEAM_M = 0.03
GROUT_M = 0.02


def _palette_table() -> np.ndarray:
    """PALETTE as cv2.LUT takes it: 256 entries of three channels."""
    table = np.zeros((256, 1, 3), dtype=np.uint8)
    table[: len(PALETTE), 0] = PALETTE
    return table


# The floor texture's texels: the tiles' and the grout's edges all fall between texels,
# so the texture draws them where a pixel's own point on the floor would.
FLOOR_TEXEL_M = 0.005


def _floor_texture() -> np.ndarray:
    """Two tiles by two of the floor, with their grout: it repeats across the building.
    Texel (row j, column i) covers x from i to i + 1 texels, and y from j to j + 1."""
    centres = (np.arange(round(2 * FLOOR_TILE_M / FLOOR_TEXEL_M)) + 0.5) * FLOOR_TEXEL_M
    x, y = centres[None, :], centres[:, None]
    odd = (np.floor(x / FLOOR_TILE_M) + np.floor(y / FLOOR_TILE_M)) % 2
    grout = (np.mod(x, FLOOR_TILE_M) < GROUT_M) | (np.mod(y, FLOOR_TILE_M) < GROUT_M)
    return np.where(grout, GROUT, np.where(odd == 0, TILE_A, TILE_B)).astype(np.uint8)


# A wall's strips: what a column of each kind shows at each height. Row i is the
# millimetre from i to i + 1 above the floor; every edge (the skirting's, a poster's, its
# chequer's, the top of the wall) falls on a whole millimetre, so the strips draw them
# where a pixel's own height would.
WALL_STRIP_STEP_M = 0.001
PAINT_STRIP, SEAM_STRIP, FRAME_STRIP = 0, 3, 6
# Strips 1, 2 (and 4, 5 on a seam) cross a poster where its chequer's column is even, and
# where it is odd.


def _wall_strips() -> np.ndarray:
    """The strips, a column each, for heights from the floor to the top of the walls."""
    mm = np.arange(round(WALL_HEIGHT_M * 1000))
    v = mm - round(POSTER_BOTTOM * 1000)
    on_poster = (v >= 0) & (v < round(POSTER_HEIGHT * 1000))
    odd_row = v // round(POSTER_CELL_HEIGHT * 1000) % 2 == 1
    strips = np.full((len(mm), 7), FRAME, dtype=np.uint8)
    for first, paint in ((PAINT_STRIP, WALL_PAINT), (SEAM_STRIP, SEAM)):
        plain = np.where(mm < round(SKIRTING_M * 1000), SKIRTING, paint)
        strips[:, first] = plain
        for odd_column in (0, 1):
            # A poster's cell is dark where its column and row are both even or both odd.
            cells = np.where(odd_row == odd_column, POSTER_DARK, POSTER_LIGHT)
            strips[:, first + 1 + odd_column] = np.where(on_poster, cells, plain)
    return strips


def _shared(table: np.ndarray) -> np.ndarray:
    """`table`, read-only: every camera uses it, on any thread."""
    table.setflags(write=False)
    return table


COLOURS = _shared(_palette_table())
FLOOR_TEXTURE = _shared(_floor_texture())
WALL_STRIPS = _shared(_wall_strips())
