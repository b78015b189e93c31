"""Occupancy grids: map_server's conventions for axes and pixels, and robot-sized obstacles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from giraff_console.planning.grid import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    OccupancyGrid,
    blocked_changes,
)


def grid_of(rows: int, cols: int, resolution: float = 0.05, origin=(0.0, 0.0)) -> OccupancyGrid:
    return OccupancyGrid(np.full((rows, cols), FREE, dtype=np.uint8), resolution, origin)


@given(
    rows=st.integers(1, 40),
    cols=st.integers(1, 40),
    data=st.data(),
    resolution=st.sampled_from([0.01, 0.05, 0.1, 0.25]),
    ox=st.floats(-50, 50),
    oy=st.floats(-50, 50),
)
def test_the_centre_of_a_cell_lies_in_that_cell(rows, cols, data, resolution, ox, oy):
    grid = grid_of(rows, cols, resolution, (ox, oy))
    row = data.draw(st.integers(0, rows - 1))
    col = data.draw(st.integers(0, cols - 1))
    assert grid.cell_of(*grid.centre_of(row, col)) == (row, col)


def test_row_zero_is_the_top_of_the_map():
    grid = grid_of(3, 4, resolution=0.5, origin=(1.0, 2.0))
    assert grid.cell_of(1.01, 2.01) == (2, 0)  # just inside the origin: lower-left cell
    assert grid.cell_of(1.01, 3.49) == (0, 0)  # top-left
    assert grid.cell_of(2.99, 3.49) == (0, 3)  # top-right
    assert grid.centre_of(0, 0) == (1.25, 3.25)
    assert grid.centre_of(2, 3) == (2.75, 2.25)


def test_moving_up_the_map_moves_up_the_rows():
    grid = grid_of(10, 10, resolution=0.1)
    row_low, _ = grid.cell_of(0.55, 0.15)
    row_high, _ = grid.cell_of(0.55, 0.85)
    assert row_high < row_low


@pytest.mark.parametrize("point", [(-0.01, 0.5), (0.5, -0.01), (1.0, 0.5), (0.5, 1.0)])
def test_a_point_off_the_map_has_no_cell(point):
    with pytest.raises(ValueError, match="off the map"):
        grid_of(10, 10, resolution=0.1).cell_of(*point)


def test_pixels_are_read_by_the_trinary_thresholds():
    # occupancy (255 - v) / 255: 89 -> 0.651 > 0.65; 90 -> 0.647; 205 -> 0.1961; 206 -> 0.192
    pixels = np.array([[0, 89, 90, 128, 205, 206, 255]], dtype=np.uint8)
    grid = OccupancyGrid.from_image(pixels, resolution=0.05)
    expected = [OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN, UNKNOWN, FREE, FREE]
    assert grid.cells.tolist() == [expected]


def test_negate_reads_white_as_occupied():
    pixels = np.array([[0, 49, 50, 128, 166, 255]], dtype=np.uint8)
    grid = OccupancyGrid.from_image(pixels, resolution=0.05, negate=1)
    # occupancy v / 255: 49 -> 0.192 < 0.196; 50 -> 0.196 > 0.196; 166 -> 0.651
    assert grid.cells.tolist() == [[FREE, FREE, UNKNOWN, UNKNOWN, OCCUPIED, OCCUPIED]]


def test_thresholds_can_be_changed():
    pixels = np.array([[128]], dtype=np.uint8)
    grid = OccupancyGrid.from_image(pixels, 0.05, occupied_thresh=0.4, free_thresh=0.1)
    assert grid.cells[0, 0] == OCCUPIED


def test_a_colour_pixel_is_the_mean_of_its_colours_and_alpha_is_ignored():
    pixels = np.array([[[255, 255, 255, 0], [0, 0, 0, 255], [255, 0, 0, 255]]], dtype=np.uint8)
    grid = OccupancyGrid.from_image(pixels, resolution=0.05)
    assert grid.cells.tolist() == [[FREE, OCCUPIED, OCCUPIED]]  # red: 85 -> 0.667


@pytest.mark.parametrize("radius_m", [0.0, 0.05, 0.12, 0.25, 0.33])
def test_inflation_grows_an_obstacle_into_a_disc_of_the_radius(radius_m):
    grid = grid_of(21, 21, resolution=0.05)
    grid.cells[10, 10] = OCCUPIED
    inflated = grid.inflated(radius_m)
    cx, cy = grid.centre_of(10, 10)
    expected = np.array(
        [
            [math.dist(grid.centre_of(r, c), (cx, cy)) <= radius_m + 1e-9 for c in range(21)]
            for r in range(21)
        ]
    )
    assert np.array_equal(inflated.cells == OCCUPIED, expected)


def test_a_radius_of_five_cells_covers_the_81_cells_of_the_gauss_circle():
    grid = grid_of(21, 21, resolution=0.05)
    grid.cells[10, 10] = OCCUPIED
    assert (grid.inflated(0.25).cells == OCCUPIED).sum() == 81


def test_inflation_leaves_the_original_grid_alone():
    grid = grid_of(9, 9)
    grid.cells[4, 4] = OCCUPIED
    grid.inflated(0.1)
    assert (grid.cells == OCCUPIED).sum() == 1


def test_unknown_space_blocks_and_grows_by_default_but_stays_unknown():
    grid = grid_of(1, 7, resolution=0.1)
    grid.cells[0, 3] = UNKNOWN
    inflated = grid.inflated(0.1)
    assert inflated.cells.tolist() == [[FREE, FREE, OCCUPIED, UNKNOWN, OCCUPIED, FREE, FREE]]
    assert inflated.blocked().tolist() == [[False, False, True, True, True, False, False]]


def test_unknown_space_can_be_left_open():
    grid = grid_of(1, 7, resolution=0.1)
    grid.cells[0, 3] = UNKNOWN
    grid.cells[0, 6] = OCCUPIED
    inflated = grid.inflated(0.1, unknown_blocks=False)
    assert inflated.cells.tolist() == [[FREE, FREE, FREE, UNKNOWN, FREE, OCCUPIED, OCCUPIED]]
    assert inflated.blocked(unknown_blocks=False).tolist() == [
        [False, False, False, False, False, True, True]
    ]


def test_set_cells_reports_only_changes_of_traversability():
    grid = grid_of(3, 3)
    grid.cells[0, 0] = UNKNOWN
    changed = grid.set_cells({(0, 0): OCCUPIED, (1, 1): OCCUPIED, (2, 2): FREE, (0, 1): UNKNOWN})
    assert sorted(changed) == [((0, 1), True), ((1, 1), True)]
    assert grid.cells[0, 0] == OCCUPIED


def test_set_cells_with_unknown_open_reports_unknown_as_free():
    grid = grid_of(3, 3)
    grid.cells[0, 0] = OCCUPIED
    changed = grid.set_cells({(0, 0): UNKNOWN, (0, 1): UNKNOWN}, unknown_blocks=False)
    assert changed == [((0, 0), False)]


def test_set_cells_off_the_grid_changes_nothing():
    grid = grid_of(3, 3)
    with pytest.raises(ValueError, match="off the grid"):
        grid.set_cells({(0, 0): OCCUPIED, (-1, 0): OCCUPIED})
    assert (grid.cells == FREE).all()


def test_blocked_changes_lists_the_cells_that_differ():
    before = np.zeros((3, 4), dtype=bool)
    after = before.copy()
    after[1, 2] = True
    before[2, 3] = True
    assert blocked_changes(before, after) == [((1, 2), True), ((2, 3), False)]


def test_cells_must_be_one_of_the_three_states():
    with pytest.raises(ValueError, match="FREE, OCCUPIED or UNKNOWN"):
        OccupancyGrid(np.array([[0, 50]], dtype=np.uint8), 0.05)


@given(st.integers(0, 2**32 - 1), st.floats(-3.0, 9.0), st.floats(-3.0, 9.0), st.floats(0.0, 4.0))
def test_the_occupied_cells_round_a_point_are_those_within_reach(seed, x, y, reach):
    rng = np.random.default_rng(seed)
    res = 0.1
    grid = OccupancyGrid(rng.choice([FREE, OCCUPIED, UNKNOWN], size=(60, 80)), res, (-0.5, 0.3))
    occupied, left, top = grid.occupied_around(x, y, reach)
    # Each cell of the window is the map's cell where its corner says, occupied as that
    # one is, and within reach (and a cell) of the point...
    for r, c in np.ndindex(occupied.shape):
        cx, cy = left + (c + 0.5) * res, top - (r + 0.5) * res
        assert occupied[r, c] == (grid.cells[grid.cell_of(cx, cy)] == OCCUPIED)
        assert abs(cx - x) <= reach + res and abs(cy - y) <= reach + res
    # ...and every occupied cell well within reach is in it.
    for row, col in zip(*np.nonzero(grid.cells == OCCUPIED), strict=True):
        cx, cy = grid.centre_of(int(row), int(col))
        if abs(cx - x) <= reach - res and abs(cy - y) <= reach - res:
            assert occupied[int((top - cy) / res), int((cx - left) / res)]
