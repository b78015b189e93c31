"""Shortest ways on the occupancy grid, found fast with numpy (§2.6.4).

D* Lite (dstar_lite.py) repairs a search cheaply when cells change, but its first search
visits cells one at a time in Python: 2.5 s on a 1000 x 1000 grid, and hundreds of
milliseconds for the legs of a first route across the care home. This module finds the
same shortest ways, on the same metric, in whole-array steps:

- 8-connected, a straight move costing 10 and a diagonal one 14, and no corner cutting
  (a diagonal move needs both cells beside it free), exactly as D* Lite plans; the costs
  are integers, so the two agree to the unit, which tests/planning/test_grid_search.py
  checks on random grids.
- The search is Dijkstra's from the goal, by buckets of width 10 (Dial's buckets; the
  "delta-stepping" of Meyer and Sanders, Journal of Algorithms 2003, with delta no wider
  than the cheapest move). No move costs less than 10, so once every cell below T is
  settled, each cell whose cost lies in [T, T + 10) is final too: the whole bucket is
  settled at once, and its moves relaxed in a handful of numpy calls. A grid is crossed
  in (cost / 10) such steps, about one per cell of the way, whatever its width.
- Other searches were weighed: scipy's csgraph.dijkstra on the same graph needs it as a
  sparse matrix, 150 to 270 bytes a cell, and building and searching it takes two to
  three times as long (bench/planning.py measures both); A* in Python expands cell by
  cell, like D* Lite; sweeping the whole grid with running minima needs a sweep per bend
  of the way, and a way through random obstacles bends hundreds of times.
- numpy's take and compress gather and select in half the time of [] indexing, which
  matters here: most of the time is spent gathering the costs of the neighbours.
- The cells of the search are the flat, padded numbering of dstar_lite.py (a border of
  blocked cells, so that a neighbour is a constant offset), and the costs are int32, so
  that D* Lite can take the result as its own state (`DStarLite` starts from it).
  Memory is the costs (4 bytes a cell), the moves allowed from each cell (1 byte) and
  a scratch array (4 bytes; D* Lite lends its g), against D* Lite's former 95 bytes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

Cell = tuple[int, int]
STRAIGHT = 10
DIAGONAL = 14
# The cost of a cell not reached (yet): no way is that long on any grid that fits in
# memory (a way through every cell of a 10000 x 10000 grid costs under 1.5 * 10**9).
UNREACHED = int(np.iinfo(np.int32).max)
# (offset, cost, corner, corner) of each move, in the order D* Lite tries them, which
# breaks ties between equally short ways the same way in both. A straight move's
# corners are its own cell, free by the time they are checked, so one loop serves both.
Move = tuple[int, int, int, int]
# For each byte of allowed moves, which of the eight moves it allows.
_MOVE_BITS = np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1, bitorder="little") > 0


def moves(width: int) -> tuple[Move, ...]:
    """The eight moves on a padded grid `width` cells wide."""
    return tuple(
        (dr * width + dc, DIAGONAL, dr * width, dc)
        if dr and dc
        else (dr * width + dc, STRAIGHT, 0, 0)
        for dr in (-1, 0, 1)
        for dc in (-1, 0, 1)
        if dr or dc
    )


def padded(blocked: np.ndarray) -> np.ndarray:
    """`blocked` with a border of blocked cells all round, as a new 2-D array."""
    rows, cols = blocked.shape
    out = np.ones((rows + 2, cols + 2), dtype=bool)
    out[1:-1, 1:-1] = blocked
    return out


def allowed_moves(blocked: np.ndarray) -> np.ndarray:
    """For each cell of a padded grid, a byte whose bit k says that move k is allowed:
    the cell and its neighbour are free, and for a diagonal both cells beside the move
    are free too. A move is allowed one way exactly when it is allowed back, so a search
    from the goal finds each cell's cost to the goal."""
    rows, cols = blocked.shape
    free = ~blocked
    inner = free[1:-1, 1:-1]
    mask = np.zeros((rows, cols), dtype=np.uint8)
    ok = np.empty((rows - 2, cols - 2), dtype=bool)
    for bit, (dr, dc) in enumerate((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc):
        np.logical_and(inner, free[1 + dr : rows - 1 + dr, 1 + dc : cols - 1 + dc], out=ok)
        if dr and dc:
            ok &= free[1 + dr : rows - 1 + dr, 1 : cols - 1]
            ok &= free[1 : rows - 1, 1 + dc : cols - 1 + dc]
        mask[1:-1, 1:-1] |= ok.view(np.uint8) << np.uint8(bit)
    return mask.ravel()


def cost_field(
    mask: np.ndarray,
    width: int,
    goal: int,
    start: int | None,
    cost: np.ndarray,
    scratch: np.ndarray,
) -> int:
    """Fill `cost` (int32, one per padded cell, UNREACHED to begin with) with each
    cell's cost to `goal`, from the moves `mask` allows; stop once `start` is settled
    (None: go on until every cell that can reach the goal has its cost).

    Returns the bound below which costs are final. Cells at or above it that are not
    UNREACHED have been reached but not settled: their cost is an upper bound (D* Lite's
    rhs, with g still unknown). `scratch` is an int32 array of the same size, whose
    contents are overwritten."""
    offsets = np.array([m[0] for m in moves(width)], dtype=np.intp)
    costs = np.array([m[1] for m in moves(width)], dtype=np.int32)
    numbers = np.arange(min(cost.size, 1 << 16), dtype=np.int32)
    cost[goal] = 0
    # Bucket j holds the cells reached with a cost in [10 j, 10 j + 10), as arrays of
    # flat indices; a cell may be in a bucket more than once, or in one that it has
    # since left for a lower one, and is then simply relaxed again to no effect.
    buckets: dict[int, list[np.ndarray]] = {0: [np.array([goal], dtype=np.intp)]}
    j = 0
    while buckets:
        if j not in buckets:
            j = min(buckets)
        parts = buckets.pop(j)
        cells = parts[0] if len(parts) == 1 else np.concatenate(parts)
        # Every move allowed from every cell of the bucket, as (cell, move) pairs.
        # (take and compress, not [] indexing: the same gathers, in half the time.)
        flat = _MOVE_BITS.take(mask.take(cells), axis=0).ravel().nonzero()[0]
        source = cells.take(flat >> 3)
        move = flat & 7
        to = source + offsets.take(move)
        reached = cost.take(source) + costs.take(move)
        better = reached < cost.take(to)
        to, reached = to.compress(better), reached.compress(better)
        np.minimum.at(cost, to, reached)
        # Keep each cell lowered once, whichever of its pairs was written last into
        # `scratch`: a cell twice in a bucket would be relaxed twice, and its
        # neighbours twice at the next step, and so on, doubling.
        if to.size > numbers.size:
            numbers = np.arange(to.size, dtype=np.int32)
        order = numbers[: to.size]
        scratch.put(to, order)
        to = to.compress(scratch.take(to) == order)
        # From [10 j, 10 j + 10) a move reaches [10 j + 10, 10 j + 24): the next two.
        near = cost.take(to) < 10 * j + 20
        for k, part in ((j + 1, to.compress(near)), (j + 2, to.compress(~near))):
            if part.size:
                buckets.setdefault(k, []).append(part)
        j += 1
        if start is not None and cost[start] < 10 * j:
            break
    return 10 * j


def descend(cost: Sequence[int], blocked: Sequence[int], width: int, start: int,
            goal: int) -> list[int] | None:  # fmt: skip
    """The way from `start` down the costs to `goal`, both included, as flat indices:
    at each cell the first move, in D* Lite's order, whose cost plus the cost beyond is
    least. The start's own cost is not read (D* Lite may have settled only its rhs);
    each cell after it must be consistent (its cost is its best move's), as both
    searches leave the way. None if the walk gets stuck, which they never leave."""
    step_moves = moves(width)
    cell, path = start, [start]
    # Each step lowers the cost by its own, so the walk ends in fewer steps than cells.
    for _ in range(len(cost)):
        if cell == goal:
            return path
        best, step = UNREACHED, cell
        for offset, move_cost, corner_a, corner_b in step_moves:
            t = cell + offset
            if blocked[t] or blocked[cell + corner_a] or blocked[cell + corner_b]:
                continue
            if move_cost + cost[t] < best:
                best, step = move_cost + cost[t], t
        if step == cell:
            return None
        cell = step
        path.append(cell)
    return None


def shortest_path(blocked: np.ndarray, start: Cell, goal: Cell) -> tuple[int, list[Cell]] | None:
    """The cost (in tenths of a cell side) and cells of a shortest way from `start` to
    `goal`, both included, on the metric of D* Lite; None if there is none."""
    grid = padded(np.asarray(blocked, dtype=bool))
    rows, cols = grid.shape
    for row, col in (start, goal):
        if not (0 <= row < rows - 2 and 0 <= col < cols - 2):
            raise ValueError(f"{(row, col)} is off the grid {(rows - 2, cols - 2)}")
    s = (start[0] + 1) * cols + start[1] + 1
    g = (goal[0] + 1) * cols + goal[1] + 1
    flat = grid.ravel()
    if flat[s] or flat[g]:
        return None
    cost = np.full(flat.size, UNREACHED, dtype=np.int32)
    cost_field(allowed_moves(grid), cols, g, s, cost, np.empty_like(cost))
    if cost[s] >= UNREACHED:
        return None
    # Python ints are quicker to index one by one than numpy's scalars.
    way = descend(cost.data, flat.data, cols, s, g)
    if way is None:
        raise RuntimeError("the way down the costs does not reach the goal")
    return int(cost[s]), [((i // cols) - 1, (i % cols) - 1) for i in way]
