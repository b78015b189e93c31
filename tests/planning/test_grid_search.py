"""The numpy search finds D* Lite's costs on D* Lite's metric, and D* Lite starts from it."""

from __future__ import annotations

import tracemalloc

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from giraff_console.planning.dstar_lite import DIAGONAL, STRAIGHT, DStarLite
from giraff_console.planning.grid_search import (
    UNREACHED,
    allowed_moves,
    cost_field,
    padded,
    shortest_path,
)
from tests.planning.test_dstar_lite import changes, check, grid_graph, grids, path_cost


def own_search_cost(blocked: np.ndarray, start, goal) -> int | None:
    """D* Lite's own search, not the numpy one: its first search runs on a grid where
    every cell but the two ends is blocked, and it then finds the way as a repair."""
    walled = np.ones_like(blocked)
    walled[start] = walled[goal] = False
    planner = DStarLite(walled, start, goal)
    planner.plan()
    planner.update_cells(((r, c), bool(blocked[r, c])) for r, c in np.ndindex(blocked.shape))
    return planner.cost


@settings(max_examples=400, deadline=None)
@given(grids())
def test_the_cost_is_d_star_lites_and_the_way_is_legal(case):
    blocked, start, goal = case
    found = shortest_path(blocked, start, goal)
    expected = DStarLite(blocked, start, goal).cost
    if expected is None:
        assert found is None
        return
    assert found is not None
    cost, path = found
    assert cost == expected
    assert path[0] == start and path[-1] == goal
    assert not blocked[start]
    assert path_cost(blocked, path) == cost


@pytest.mark.parametrize("seed", range(12))
def test_the_cost_is_that_of_d_star_lites_own_search_on_random_grids(seed):
    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(2, 40, size=2)
    blocked = rng.random((rows, cols)) < rng.choice([0.1, 0.25, 0.35])
    start = (int(rng.integers(rows)), int(rng.integers(cols)))
    goal = (int(rng.integers(rows)), int(rng.integers(cols)))
    blocked[start] = blocked[goal] = False
    found = shortest_path(blocked, start, goal)
    assert (found[0] if found else None) == own_search_cost(blocked, start, goal)


@pytest.mark.parametrize("seed", range(8))
def test_the_whole_field_is_every_cells_cost_to_the_goal(seed):
    rng = np.random.default_rng(seed)
    blocked = rng.random((23, 31)) < 0.3
    goal = (11, 15)
    blocked[goal] = False
    grid = padded(blocked)
    cost = np.full(grid.size, UNREACHED, dtype=np.int32)
    width = grid.shape[1]
    cost_field(
        allowed_moves(grid),
        width,
        (goal[0] + 1) * width + goal[1] + 1,
        None,
        cost,
        np.empty_like(cost),
    )
    lengths = nx.single_source_dijkstra_path_length(grid_graph(blocked), goal)
    field = cost.reshape(grid.shape)[1:-1, 1:-1]
    for r, c in np.ndindex(blocked.shape):
        assert field[r, c] == lengths.get((r, c), UNREACHED)


def test_a_search_stopped_at_the_start_has_settled_every_cheaper_cell():
    blocked = np.zeros((40, 40), dtype=bool)
    grid = padded(blocked)
    width = grid.shape[1]
    cost = np.full(grid.size, UNREACHED, dtype=np.int32)
    start = 1 * width + 1 + 5  # (0, 5)
    bound = cost_field(
        allowed_moves(grid), width, 20 * width + 21, start, cost, np.empty_like(cost)
    )
    field = cost.reshape(grid.shape)[1:-1, 1:-1]
    exact = nx.single_source_dijkstra_path_length(grid_graph(blocked), (19, 20))
    assert field[0, 5] == exact[(0, 5)] < bound
    settled = field < bound
    for r, c in zip(*np.nonzero(settled), strict=True):
        assert field[r, c] == exact[(r, c)]
    # What was reached beyond the bound is an upper bound, never below the truth.
    for r, c in zip(*np.nonzero(~settled & (field < UNREACHED)), strict=True):
        assert field[r, c] >= exact[(r, c)]
    assert (field == UNREACHED).any()  # it stopped before the far corners


def test_no_way_and_blocked_ends_are_none():
    wall = np.zeros((5, 5), dtype=bool)
    wall[:, 2] = True
    assert shortest_path(wall, (0, 0), (4, 4)) is None
    assert shortest_path(wall, (0, 2), (0, 0)) is None
    assert shortest_path(wall, (0, 0), (0, 2)) is None


def test_a_diagonal_past_a_corner_is_refused():
    blocked = np.array([[False, True], [False, False]])
    assert shortest_path(blocked, (0, 0), (1, 1)) == (2 * STRAIGHT, [(0, 0), (1, 0), (1, 1)])
    assert shortest_path(np.zeros((2, 2), dtype=bool), (0, 0), (1, 1)) == (
        DIAGONAL,
        [(0, 0), (1, 1)],
    )


def test_a_cell_off_the_grid_is_refused():
    with pytest.raises(ValueError, match="off the grid"):
        shortest_path(np.zeros((3, 3), dtype=bool), (0, 0), (3, 0))


def test_d_star_lite_replans_from_the_numpy_start():
    # The first plan comes from the numpy search, stopped at the start; the cells it
    # reached but did not settle are D* Lite's queue, from which it repairs.
    blocked = np.zeros((30, 30), dtype=bool)
    planner = DStarLite(blocked, (0, 0), (29, 29))
    first = planner.plan()
    assert first is not None and planner.cost == 29 * DIAGONAL
    wall = [((r, 15), True) for r in range(25)]
    planner.update_cells(wall)
    blocked[:25, 15] = True
    planner.move_to(first[3])
    expected = nx.dijkstra_path_length(grid_graph(blocked), first[3], (29, 29))
    assert planner.cost == expected
    assert path_cost(blocked, planner.plan()) == expected


def test_d_star_lite_takes_at_most_40_bytes_a_cell():
    rng = np.random.default_rng(1)
    blocked = rng.random((300, 300)) < 0.2
    blocked[0, 0] = blocked[-1, -1] = False
    tracemalloc.start()
    try:
        planner = DStarLite(blocked, (0, 0), (299, 299))
        planner.plan()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak / blocked.size <= 40


@settings(max_examples=300, deadline=None)
@given(grids(max_side=20), st.lists(changes, min_size=1, max_size=10))
def test_a_repair_given_up_for_a_fresh_search_is_still_optimal(case, steps):
    # White-box: a repair budget of a few cells makes nearly every replan start afresh.
    blocked, start, goal = case
    blocked = blocked.copy()
    planner = DStarLite(blocked, start, goal)
    planner._budget = 3
    check(planner, blocked)
    rows, cols = blocked.shape
    for kind, where, count in steps:
        path = planner.plan()
        if kind == "move":
            if path is not None:
                planner.move_to(path[min(where, len(path) - 1)])
        else:
            cells = [divmod((where + i * 7919) % (rows * cols), cols) for i in range(count)]
            toggled = [(cell, not blocked[cell]) for cell in cells]
            for cell, now in toggled:
                blocked[cell] = now
            planner.update_cells(toggled)
        check(planner, blocked)
