"""Solid walls and obstacles: a disc-shaped robot stops against them.

The thesis's simulator computed "only the motor odometry ... not the Giraff's resulting
position in space" (§3.2.2), so nothing could stop it; this one knows where the robot
is, and a robot that drives into a wall must stop there with its wheels stalled, as a
real one does (§2.3.2: "motion is commanded but the odometry stops changing"). The
robot is a disc (the Giraff's base is about 0.6 m across) and walls, closed doors and
boxes are line segments; the floor plan's side (runtime/sim_site.py) hands them over, since the
simulator knows no floor plans.

Only motion into something is refused: a robot against a wall can back off, drive
along it or turn in place (a disc turning on the spot keeps its footprint). The test
runs on every integration step of the wheels, so it has to be cheap: the clearance
round a point is remembered, and a step that stays within it needs no geometry at all;
near a wall, the exact test is vectorised over the segments nearby.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence

import numpy as np

from giraff_console.sim.surroundings import Surroundings

Point = tuple[float, float]

# A disc this close to a segment (beyond its radius) is already against it: motion
# into it is refused and it is not "entered" again. Well below anything that shows.
CONTACT_M = 1e-6
# Motion along a wall the disc touches is allowed unless it leans into it by more than
# this cosine: rounding alone must not stall a robot sliding along a wall.
GRAZING_COS = 1e-6
# How far round a point the clearance is looked for; steps within it are free.
REACH_M = 1.0
# Above this many segments, only those in the squares (of BUCKET_M) near a move are
# tested: a surveyed map's grid gives thousands of small edges.
BUCKETED_ABOVE = 1000
BUCKET_M = 1.0
# How many looked-up sets of nearby segments are kept.
RECENT_LOOKUPS = 64


class Solids:
    """Fixed walls plus what the operator puts down or shuts (`surroundings`), for a
    robot disc of `radius` metres. Not thread-safe: the board calls it under its lock."""

    def __init__(self, walls: Iterable[tuple[Point, Point]], radius: float,
                 surroundings: Surroundings | None = None) -> None:  # fmt: skip
        if not radius > 0:
            raise ValueError(f"the robot needs a positive radius, not {radius}")
        pairs = [(a, b) for a, b in walls if a != b]
        starts = np.array([a for a, _ in pairs], dtype=np.float64).reshape(-1, 2)
        ends = np.array([b for _, b in pairs], dtype=np.float64).reshape(-1, 2)
        self.radius = float(radius)
        self.surroundings = surroundings
        self._walls = _Segments(starts, ends)
        self._buckets = _bucket(starts, ends) if len(pairs) > BUCKETED_ABOVE else None
        self._recent: dict[tuple[int, int, int, int], _Segments] = {}
        # The clearance remembered: no solid lies within `radius + clear` of (x, y).
        self._anchor: tuple[float, float, float, int] | None = None
        self._obstacles_seen = -1
        self._obstacles = _Segments(np.empty((0, 2)), np.empty((0, 2)))

    @classmethod
    def from_grid(cls, occupied: np.ndarray, resolution: float, origin: Point, radius: float,
                  surroundings: Surroundings | None = None) -> Solids:  # fmt: skip
        """Walls round the occupied cells of a ROS-style grid (row 0 at the top of the
        map, `origin` the lower-left corner of the lower-left cell): for a floor plan
        that has a map but no outlines."""
        return cls(grid_edges(occupied, resolution, origin), radius, surroundings)

    @property
    def wall_count(self) -> int:
        return len(self._walls.a)

    def __deepcopy__(self, memo: dict) -> Solids:
        """The building, not a copy: a copied board (a test running it on alone) drives
        in the same one. What is remembered of it holds wherever it is asked from."""
        return self

    # -- queries --------------------------------------------------------------------

    def free_fraction(self, x0: float, y0: float, x1: float, y1: float) -> float:
        """How much of the straight move from (x0, y0) to (x1, y1), 0 to 1, the robot can
        make before it pushes into something: 1.0 when nothing is in the way, 0.0 when
        it is already against something and the move goes into it."""
        if x0 == x1 and y0 == y1:
            return 1.0
        revision = self._refresh()
        anchor = self._anchor
        if anchor is not None and anchor[3] == revision:
            ax, ay, clear, _ = anchor
            if max(math.hypot(x0 - ax, y0 - ay), math.hypot(x1 - ax, y1 - ay)) <= clear:
                return 1.0
        clear = self.clearance(x0, y0)
        self._anchor = (x0, y0, clear, revision)
        if math.hypot(x1 - x0, y1 - y0) <= clear:
            return 1.0
        margin = self.radius + CONTACT_M
        near = self._near(
            (min(x0, x1) - margin, min(y0, y1) - margin),
            (max(x0, x1) + margin, max(y0, y1) + margin),
        )
        fractions = [
            segments.first_contact(x0, y0, x1 - x0, y1 - y0, self.radius)
            for segments in (near, self._obstacles)
            if len(segments.a)
        ]
        return min(fractions, default=1.0)

    def clearance(self, x: float, y: float) -> float:
        """How far the robot at (x, y) could move in any direction before touching
        anything (negative when it overlaps), looking no further than REACH_M."""
        self._refresh()
        near = self._near((x - REACH_M, y - REACH_M), (x + REACH_M, y + REACH_M))
        distance = min(near.distance(x, y), self._obstacles.distance(x, y), REACH_M)
        return distance - self.radius

    def touches(self, x: float, y: float) -> bool:
        """Whether the robot at (x, y) overlaps a wall, a closed door or a box."""
        return self.clearance(x, y) <= CONTACT_M

    # -- internals ------------------------------------------------------------------

    def _refresh(self) -> int:
        """Take the operator's boxes and doors as they are now; their revision."""
        if self.surroundings is None:
            return 0
        snapshot = self.surroundings.snapshot()
        if snapshot.revision != self._obstacles_seen:
            self._obstacles = _Segments(snapshot.starts, snapshot.ends)
            self._obstacles_seen = snapshot.revision
        return snapshot.revision

    def _near(self, lo: Point, hi: Point) -> _Segments:
        """The fixed walls that may lie within the box from `lo` to `hi`."""
        if self._buckets is None:
            return self._walls
        key = (
            math.floor(lo[0] / BUCKET_M), math.floor(hi[0] / BUCKET_M),
            math.floor(lo[1] / BUCKET_M), math.floor(hi[1] / BUCKET_M),
        )  # fmt: skip
        near = self._recent.get(key)
        if near is None:
            # A robot asks about the same few squares over and over: keep the last ones.
            if len(self._recent) >= RECENT_LOOKUPS:
                self._recent.pop(next(iter(self._recent)))
            buckets = self._buckets
            picked = [
                buckets[(i, j)]
                for i in range(key[0], key[1] + 1)
                for j in range(key[2], key[3] + 1)
                if (i, j) in buckets
            ]
            index = np.unique(np.concatenate(picked)) if picked else np.empty(0, dtype=np.intp)
            near = self._recent[key] = self._walls.subset(index)
        return near


class _Segments:
    """Line segments with what the disc tests need precomputed."""

    def __init__(self, starts: np.ndarray, ends: np.ndarray) -> None:
        edge = ends - starts
        length = np.hypot(edge[:, 0], edge[:, 1])
        keep = length > 0
        self.a, self.b, self.length = starts[keep], ends[keep], length[keep]
        self.u = edge[keep] / self.length[:, None] if keep.any() else np.empty((0, 2))

    def subset(self, index: np.ndarray) -> _Segments:
        part = _Segments.__new__(_Segments)
        part.a, part.b = self.a[index], self.b[index]
        part.length, part.u = self.length[index], self.u[index]
        return part

    def distance(self, x: float, y: float) -> float:
        """The distance from (x, y) to the nearest segment; inf with none."""
        if not len(self.a):
            return math.inf
        wx, wy = x - self.a[:, 0], y - self.a[:, 1]
        along = np.clip(wx * self.u[:, 0] + wy * self.u[:, 1], 0.0, self.length)
        return float(np.hypot(wx - along * self.u[:, 0], wy - along * self.u[:, 1]).min())

    def first_contact(self, x: float, y: float, dx: float, dy: float, r: float) -> float:
        """The least fraction, 0 to 1, of the move (dx, dy) from (x, y) at which a disc of
        radius `r` first touches a segment while moving towards it; 1.0 if none.

        The disc's centre enters the segment's capsule (the segment grown by r): through
        one of its long sides, or through a round end. A disc already touching a segment
        is stopped at once if the move leans into it; if not, the distance to that
        segment only grows along the move (the distance to a convex set along a line is
        convex), so it can be left alone.
        """
        ux, uy, length = self.u[:, 0], self.u[:, 1], self.length
        wx, wy = x - self.a[:, 0], y - self.a[:, 1]
        along = wx * ux + wy * uy
        nearest = np.clip(along, 0.0, length)
        ox, oy = wx - nearest * ux, wy - nearest * uy  # from the nearest point to the centre
        gap = np.hypot(ox, oy)
        touching = gap <= r + CONTACT_M
        step = math.hypot(dx, dy)
        if touching.any():
            closing = (ox * dx + oy * dy)[touching]
            if (closing < -GRAZING_COS * gap[touching] * step).any():
                return 0.0
        best = np.full(len(length), np.inf)
        # The long sides: the perpendicular offset h moves from |h| > r to |h| = r.
        h0 = wx * -uy + wy * ux
        dh = dx * -uy + dy * ux
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (np.abs(h0) - r) / np.abs(dh)
            at = along + t * (dx * ux + dy * uy)
            side = (~touching) & (np.abs(h0) > r) & (h0 * dh < 0) & (at >= 0) & (at <= length)
            best = np.where(side & (t <= 1.0), t, best)
            # The round ends: |w + t (dx, dy)|^2 = r^2, entering from outside.
            for cx, cy in ((wx, wy), (wx - length * ux, wy - length * uy)):
                b = cx * dx + cy * dy
                c = cx * cx + cy * cy - r * r
                disc = b * b - step * step * c
                t = (-b - np.sqrt(disc)) / (step * step)
                end = (~touching) & (c > 0) & (b < 0) & (disc >= 0) & (t <= 1.0)
                best = np.where(end, np.minimum(best, t), best)
        first = float(best.min()) if len(best) else math.inf
        return min(max(first, 0.0), 1.0)


def _bucket(starts: np.ndarray, ends: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """Segment numbers by the BUCKET_M squares their bounding boxes overlap."""
    buckets: dict[tuple[int, int], list[int]] = defaultdict(list)
    low = np.floor(np.minimum(starts, ends) / BUCKET_M).astype(int)
    high = np.floor(np.maximum(starts, ends) / BUCKET_M).astype(int)
    for n, ((i0, j0), (i1, j1)) in enumerate(zip(low.tolist(), high.tolist(), strict=True)):
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                buckets[(i, j)].append(n)
    return {key: np.array(numbers, dtype=np.intp) for key, numbers in buckets.items()}


def grid_edges(occupied: np.ndarray, resolution: float, origin: Point) -> list[tuple[Point, Point]]:
    """The boundary between occupied and other cells as segments, runs along a row or
    a column merged into one. Row 0 is the top of the map (map_server's convention)."""
    cells = np.asarray(occupied, dtype=bool)
    rows = cells.shape[0]
    ox, oy = origin
    padded = np.pad(cells, 1)
    edges: list[tuple[Point, Point]] = []
    # Between row k-1 and row k (k = 0..rows): map y = oy + (rows - k) * resolution.
    horizontal = padded[:-1, 1:-1] != padded[1:, 1:-1]
    for k, start, stop in _runs(horizontal):
        y = oy + (rows - k) * resolution
        edges.append(((ox + start * resolution, y), (ox + stop * resolution, y)))
    # Between column k-1 and column k (k = 0..cols): map x = ox + k * resolution.
    vertical = (padded[1:-1, :-1] != padded[1:-1, 1:]).T
    for k, start, stop in _runs(vertical):
        x = ox + k * resolution
        edges.append(((x, oy + (rows - start) * resolution), (x, oy + (rows - stop) * resolution)))
    return edges


def _runs(mask: np.ndarray) -> Sequence[tuple[int, int, int]]:
    """(line, first, past-last) of every run of True along each line of `mask`."""
    padded = np.pad(mask, ((0, 0), (1, 1))).astype(np.int8)
    change = np.diff(padded, axis=1)
    starts = np.nonzero(change == 1)
    stops = np.nonzero(change == -1)
    return list(zip(starts[0].tolist(), starts[1].tolist(), stops[1].tolist(), strict=True))
