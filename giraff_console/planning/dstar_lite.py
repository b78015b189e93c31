"""D* Lite on an 8-connected grid: replanning as obstacles appear and vanish (§2.6.4).

The thesis recommends D* rather than A* for a robot that maps obstacles as it goes, "to
minimize time wasted replanning the route whenever an obstacle is detected". This is
D* Lite (S. Koenig and M. Likhachev, "D* Lite", AAAI 2002), in the optimised version of
the paper's Figure 4: it searches backwards from the goal, so when cells change near the
robot only the part of the search those changes invalidate is repaired, and the robot's
own movement costs nothing but an increase of the key modifier km.

The grid is 8-connected without corner cutting: a diagonal move needs both orthogonal
neighbours free, or the robot would clip the corner of an obstacle. Costs are integers,
10 for a straight move and 14 for a diagonal one, and the heuristic is the octile
distance in the same units, which is admissible and consistent. Integer keys compare
exactly, so the search never stops early on a rounding error.

Cells are numbered in a flat array with a one-cell border of blocked cells, so that
neighbours are constant offsets and the inner loop needs no bounds checks.

The first search is grid_search.py's, in whole-array numpy steps (2.5 s became about
0.12 s on a 1000 x 1000 grid): a Dijkstra from the goal, stopped once the start is
settled, is a state D* Lite could itself have reached. Its settled cells are consistent
(g = rhs, their cost to the goal), the cells it reached but did not settle are
overconsistent (g unknown, rhs its cost so far) and go into the queue, and every other
cell is at infinity both ways. D* Lite's own searches then only repair that state.

Memory: g and rhs are int32 numpy arrays, read and written one cell at a time through
memoryviews, and the blocked cells are bytes: 9 bytes a cell, where Python lists of
ints (and of each cell's row and column) took 95. Infinity is UNREACHED, 2**31 - 1,
which no way on a grid that fits in memory costs; it adds and compares exactly with
the Python ints of the keys. Reading a memoryview is slower than reading a list, which
the replans (a few hundred cells) hardly feel.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable

import numpy as np

from giraff_console.planning.grid_search import (
    DIAGONAL,
    STRAIGHT,
    UNREACHED,
    allowed_moves,
    cost_field,
    descend,
    moves,
)

Cell = tuple[int, int]
REPAIR_BUDGET_MIN = 4096
REPAIR_BUDGET_FRACTION = 64
__all__ = ["DIAGONAL", "STRAIGHT", "UNREACHED", "Cell", "DStarLite"]


class DStarLite:
    """A shortest path from `start` to `goal` through the cells that are not `blocked`,
    kept up to date as cells change and the robot moves.

    `plan()` returns the path, or None when there is none. After `move_to` and
    `update_cells`, `plan()` repairs the previous search instead of starting again. The
    goal is fixed; a new goal needs a new planner.
    """

    def __init__(self, blocked: np.ndarray, start: Cell, goal: Cell) -> None:
        blocked = np.asarray(blocked, dtype=bool)
        if blocked.ndim != 2:
            raise ValueError(f"a grid is two-dimensional, not {blocked.shape}")
        self.shape: tuple[int, int] = blocked.shape
        rows, cols = blocked.shape
        width = cols + 2
        self._width = width
        n = (rows + 2) * width
        # The blocked cells as bytes, with a numpy view of the same memory for the
        # first search.
        self._blocked = bytearray(n)
        self._blocked_array = np.frombuffer(self._blocked, dtype=bool).reshape(rows + 2, width)
        self._blocked_array[:] = True
        self._blocked_array[1:-1, 1:-1] = blocked
        self._moves = moves(width)
        self._start = self._index(start)
        self._goal = self._index(goal)
        self._g_array = np.full(n, UNREACHED, dtype=np.int32)
        self._rhs_array = np.full(n, UNREACHED, dtype=np.int32)
        # Python ints one at a time, for the inner loops.
        self._g = self._g_array.data
        self._rhs = self._rhs_array.data
        self._km = 0
        # The priority queue is a binary heap with lazy deletion: heapq cannot change or
        # remove an entry in place, so an update pushes a new entry and `_queued` maps
        # each queued cell to its one live entry. Entries that are no longer live are
        # dropped when they reach the top. This is O(log n) per operation, against the
        # O(n) of searching the heap to delete.
        self._heap: list[tuple[int, int, int]] = []
        self._queued: dict[int, tuple[int, int, int]] = {}
        # Until the first search, changes and moves only change the grid and the start.
        self._searched = False
        # How much a repair may do (a unit: a cell taken from the queue; a cell raised,
        # whose neighbours are looked at again, counts 9) before it gives up for a fresh
        # numpy search: on a 1000 x 1000 grid, about 60 ms against a search's 150 ms
        # (bench/planning.py's "door closes"). A small repair never comes near it.
        self._budget = max(REPAIR_BUDGET_MIN, n // REPAIR_BUDGET_FRACTION)

    @property
    def start(self) -> Cell:
        return self._cell(self._start)

    @property
    def goal(self) -> Cell:
        return self._cell(self._goal)

    @property
    def cost(self) -> int | None:
        """The cost of the shortest path in tenths of a cell side, or None if none."""
        if not self._compute():
            return None
        # Finite once there is a path, and a finite cost is a sum of the integer move costs.
        return int(self._rhs[self._start])

    def plan(self) -> list[Cell] | None:
        """The shortest path from start to goal, both included, or None if there is none."""
        if not self._compute():
            return None
        # Each step lowers g by its own cost; g is consistent along the way (the start
        # is, and so is each best successor of a consistent cell).
        path = descend(self._g, self._blocked, self._width, self._start, self._goal)
        if path is None:
            raise RuntimeError("D* Lite could not follow its own search to the goal")
        return [self._cell(i) for i in path]

    def move_to(self, cell: Cell) -> None:
        """The robot is now at `cell`. Keys already queued were computed from the old
        start; raising km by the heuristic between the two keeps them lower bounds, so
        nothing is re-queued (the paper does this at the next change of costs; doing it
        on each move is equally correct, since the heuristic obeys the triangle
        inequality, and lets `plan()` run at any time)."""
        new = self._index(cell)
        if self._searched:
            self._km += self._heuristic(self._start, new)
        self._start = new

    def update_cells(self, changes: Iterable[tuple[Cell, bool]]) -> None:
        """Cells became blocked (True) or free (False). The next `plan()` replans."""
        blocked = self._blocked
        touched: set[int] = set()
        for cell, now_blocked in changes:
            i = self._index(cell)
            if blocked[i] != bool(now_blocked):
                blocked[i] = bool(now_blocked)
                # A cell's state is in the cost of the moves into and out of it, and of
                # the diagonal moves round its corners: all from the cell or its neighbours.
                touched.add(i)
                touched.update(i + offset for offset, _, _, _ in self._moves)
        if not self._searched:
            return  # the first search will see the grid as it is
        touched.discard(self._goal)
        for s in touched:
            # Recomputing rhs from all eight successors gives the same result as the
            # paper's per-edge test, at the cost of a handful of lookups.
            self._rhs[s] = self._lookahead(s)
            self._update_vertex(s)

    def _index(self, cell: Cell) -> int:
        row, col = cell
        if not (0 <= row < self.shape[0] and 0 <= col < self.shape[1]):
            raise ValueError(f"{cell} is off the grid {self.shape}")
        return (row + 1) * self._width + col + 1

    def _cell(self, i: int) -> Cell:
        row, col = divmod(i, self._width)
        return row - 1, col - 1

    def _heuristic(self, a: int, b: int) -> int:
        """The octile distance between two cells, in the units of the move costs."""
        ar, ac = divmod(a, self._width)
        br, bc = divmod(b, self._width)
        dr, dc = abs(ar - br), abs(ac - bc)
        return STRAIGHT * max(dr, dc) + (DIAGONAL - STRAIGHT) * min(dr, dc)

    def _lookahead(self, s: int) -> int:
        """rhs(s): the best cost to the goal through one of s's successors."""
        blocked, g = self._blocked, self._g
        if blocked[s]:
            return UNREACHED
        best = UNREACHED
        for offset, cost, corner_a, corner_b in self._moves:
            t = s + offset
            if blocked[t] or blocked[s + corner_a] or blocked[s + corner_b]:
                continue
            if cost + g[t] < best:
                best = cost + g[t]
        return best

    def _update_vertex(self, s: int) -> None:
        g, rhs = self._g[s], self._rhs[s]
        if g != rhs:
            m = g if g < rhs else rhs
            entry = (m + self._heuristic(self._start, s) + self._km, m, s)
            self._queued[s] = entry
            heapq.heappush(self._heap, entry)
        else:
            self._queued.pop(s, None)

    def _forget(self) -> None:
        """Drop the search, so that the next one starts afresh."""
        self._g_array.fill(UNREACHED)
        self._rhs_array.fill(UNREACHED)
        self._heap, self._queued = [], {}
        self._searched = False

    def _first_search(self) -> None:
        """Start from grid_search's costs: settled cells consistent, reached ones queued."""
        width, start = self._width, self._start
        g, rhs = self._g_array, self._rhs_array
        rhs[self._goal] = 0
        # g is free until the costs are in, and serves as the search's scratch array.
        bound = cost_field(allowed_moves(self._blocked_array), width, self._goal, start, rhs, g)
        g.fill(UNREACHED)
        np.copyto(g, rhs, where=rhs < bound)
        reached = np.flatnonzero((rhs >= bound) & (rhs < UNREACHED))
        self._km = 0
        sr, sc = divmod(start, width)
        rows, cols = np.divmod(reached, width)
        dr, dc = np.abs(rows - sr), np.abs(cols - sc)
        keys = (
            rhs[reached]
            + STRAIGHT * np.maximum(dr, dc)
            + (DIAGONAL - STRAIGHT) * np.minimum(dr, dc)
        )
        entries = list(zip(keys.tolist(), rhs[reached].tolist(), reached.tolist(), strict=True))
        self._queued = {entry[2]: entry for entry in entries}
        heapq.heapify(entries)
        self._heap = entries
        self._searched = True

    def _compute(self) -> bool:
        """ComputeShortestPath; False if there is no path.

        A blocked start or goal has no path, and the search waits until it is freed.
        """
        blocked, start, goal = self._blocked, self._start, self._goal
        if blocked[start] or blocked[goal]:
            return False
        if not self._searched:
            self._first_search()
        g, rhs, heap, queued, moves = self._g, self._rhs, self._heap, self._queued, self._moves
        if len(heap) > 2 * len(queued) + 1024:
            # Dead entries deep in the heap are only dropped when they surface; on a long
            # mission they would pile up, so now and then the heap is rebuilt from the
            # live ones, in time linear in its size.
            heap[:] = queued.values()
            heapq.heapify(heap)
        width, km = self._width, self._km
        sr, sc = divmod(start, width)
        straight, extra = STRAIGHT, DIAGONAL - STRAIGHT  # octile distance, inlined
        heappop, heappush, heapreplace = heapq.heappop, heapq.heappush, heapq.heapreplace
        budget = self._budget
        while heap:
            entry = heap[0]
            k1, k2, u = entry
            if queued.get(u) is not entry:  # superseded or removed: lazy deletion
                heappop(heap)
                continue
            # Done once the start is not underconsistent and its key is no more than
            # the smallest queued key: nothing left in the queue can lower its cost.
            start_rhs = rhs[start]
            if start_rhs <= g[start] and (
                k1 > start_rhs + km or (k1 == start_rhs + km and k2 >= start_rhs)
            ):
                break
            gu, ru = g[u], rhs[u]
            m = gu if gu < ru else ru
            ur, uc = divmod(u, width)
            dr, dc = abs(ur - sr), abs(uc - sc)
            h = straight * dr + extra * dc if dr > dc else straight * dc + extra * dr
            if k1 < m + h + km or (k1 == m + h + km and k2 < m):  # queued before a move
                entry = (m + h + km, m, u)
                queued[u] = entry
                heapreplace(heap, entry)
                continue
            budget -= 1
            if budget < 0:
                # A repair this large (a door closed across the way, far from the robot)
                # is quicker searched afresh by numpy than finished cell by cell.
                self._forget()
                return self._compute()
            heappop(heap)
            del queued[u]
            if gu > ru:  # overconsistent: settle g and relax the predecessors
                g[u] = ru  # u is free: a blocked cell's rhs is infinite, the goal's aside
                for offset, cost, corner_a, corner_b in moves:
                    # Most neighbours have been reached already, so the cheap test first.
                    s = u + offset
                    v = ru + cost
                    if v >= rhs[s]:  # always true of the goal, whose rhs is 0
                        continue
                    if blocked[s] or blocked[u + corner_a] or blocked[u + corner_b]:
                        continue
                    rhs[s] = v
                    gs = g[s]
                    if gs == v:
                        queued.pop(s, None)
                        continue
                    ms = v if v < gs else gs
                    sr_, sc_ = divmod(s, width)
                    dr, dc = abs(sr_ - sr), abs(sc_ - sc)
                    h = straight * dr + extra * dc if dr > dc else straight * dc + extra * dr
                    entry = (ms + h + km, ms, s)
                    queued[s] = entry
                    heappush(heap, entry)
            else:  # underconsistent: raise g and repair those that relied on it
                budget -= 8  # a lookahead for each neighbour that relied on it
                g[u] = UNREACHED
                if not blocked[u]:
                    for offset, cost, corner_a, corner_b in moves:
                        s = u + offset
                        if blocked[s] or blocked[u + corner_a] or blocked[u + corner_b]:
                            continue
                        if s != goal and rhs[s] == gu + cost:
                            rhs[s] = self._lookahead(s)
                            self._update_vertex(s)
                self._update_vertex(u)
        return rhs[start] != UNREACHED
