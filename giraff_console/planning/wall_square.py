"""The square a building is built on (issue 29): the direction its walls run in, modulo a
right angle, as one revolution of the range sensor sees them.

Most buildings have their walls in two directions a right angle apart. The teaching
drive's heading drifts: a long wall first seen with the heading a degree or two off is
drawn tilted, scan matching then keeps the pose true to the tilted wall, and in a wing
driven once the loop closure at `map save` has nothing to take the heading back with
(docs/performance.md, "Why the west wing's map is off"). A revolution's walls say its
heading modulo 90 degrees, whatever the map says; loop_closure.py ties each keyframe whose
walls run square to the dock's square. A room whose walls run otherwise, or clutter with
no long straight wall, gives no square.

Pure numpy; no I/O.
"""

from __future__ import annotations

import math

import numpy as np

QUARTER = math.pi / 2
# The first search: every whole degree, the hits projected across each direction into
# bins of BIN_M; a wall along a direction piles its hits into one or two bins.
COARSE_STEP = math.radians(1.0)
BIN_M = 0.05
# A wall: at least WALL_HITS hits within WALL_BAND_M of a straight line, running on
# along it for WALL_SPAN_M with no gap wider than WALL_GAP_M (the sensor's degree is
# 0.1 m at 6 m, and a ragged wall drops hits out of the band), and bowing from it by at
# most WALL_BOW_M over its span (a parabola fitted to the hits). A doorway's jamb, a
# bed's end or a chair leg is no wall, nor are hits scattered over a room that happen
# to line up, nor a curved wall: one of 4 m radius keeps within the band for 1.4 m, but
# bows 0.06 m over it. On the recorded home drives 2 cm kept 286 of 355 keyframes
# squared and no round room of 3-6 m radius (tests/mapping); 1 cm kept 239.
WALL_BAND_M = 0.03
WALL_HITS = 8
WALL_SPAN_M = 1.0
WALL_GAP_M = 0.5
WALL_BOW_M = 0.02
# A square: walls spanning SQUARE_SPAN_M in all, each within WALLS_AGREE of their
# direction (modulo 90 degrees), some of them at right angles to the others (parallel
# walls alone, a corridor's, would say nothing of a building whose rooms are not
# square); walls that disagree are left out.
SQUARE_SPAN_M = 2.0
WALLS_AGREE = math.radians(1.0)


def quarter_turn(angle: np.ndarray | float) -> np.ndarray | float:
    """`angle` modulo a right angle, in [-pi/4, pi/4)."""
    return np.remainder(np.asarray(angle) + QUARTER / 2, QUARTER) - QUARTER / 2


def square_of(points: np.ndarray) -> float | None:
    """The direction, modulo 90 degrees, in which the walls among the hits `points`
    ((N, 2), finite, metres, the robot's frame) run: radians in [-pi/4, pi/4), in the
    robot's frame; None if they show too little straight wall, or walls that do not run
    square."""
    if len(points) < 2 * WALL_HITS:
        return None
    coarse = _coarse_direction(points)
    walls: list[tuple[float, float, int]] = []  # each wall's direction, span and side
    left = np.ones(len(points), dtype=bool)
    for side, across in enumerate((coarse, coarse + QUARTER)):
        # A wall along `across + 90 degrees` lies at one distance along `across`.
        offset = points @ np.array([math.cos(across), math.sin(across)])
        codes = np.floor(offset / BIN_M).astype(np.int64)
        codes -= codes.min()
        counts = np.bincount(codes[left], minlength=int(codes.max()) + 1)
        for code in np.argsort(counts)[::-1]:
            if counts[code] < WALL_HITS:
                break
            near = left & (np.abs(codes - code) <= 1)
            wall = _wall(points, near)
            if wall is None:
                continue
            direction, span, on = wall
            walls.append((direction, span, side))
            left &= ~on
    if not walls:
        return None
    directions = np.array([quarter_turn(d - coarse) for d, _, _ in walls]) + coarse
    spans = np.array([s for _, s, _ in walls])
    sides = np.array([side for _, _, side in walls])
    middle = float(np.median(directions))
    agree = np.abs(directions - middle) <= WALLS_AGREE
    if spans[agree].sum() < SQUARE_SPAN_M or len(set(sides[agree].tolist())) < 2:
        return None
    return float(quarter_turn(float(np.average(directions[agree], weights=spans[agree]))))


def _coarse_direction(points: np.ndarray) -> float:
    """The whole degree, modulo 90, across which the hits pile up most sharply."""
    angles = np.arange(-QUARTER / 2, QUARTER / 2, COARSE_STEP)
    sharpest, best = -1.0, 0.0
    for angle in angles:
        u = points @ np.array([math.cos(angle), math.sin(angle)])
        v = points @ np.array([-math.sin(angle), math.cos(angle)])
        sharpness = 0.0
        for offset in (u, v):
            codes = np.floor(offset / BIN_M).astype(np.int64)
            counts = np.bincount(codes - codes.min())
            sharpness += float(np.dot(counts, counts))
        if sharpness > sharpest:
            sharpest, best = sharpness, float(angle)
    return best


def _wall(points: np.ndarray,
          near: np.ndarray) -> tuple[float, float, np.ndarray] | None:  # fmt: skip
    """The straight wall among the hits `near` (a mask into `points`): its direction, its
    span, and which hits lie on it; None if they make no wall."""
    on = near
    for _ in range(3):
        if np.count_nonzero(on) < WALL_HITS:
            return None
        chosen = points[on]
        centre = chosen.mean(axis=0)
        _, _, axes = np.linalg.svd(chosen - centre, full_matrices=False)
        along, normal = axes[0], axes[1]
        on = near & (np.abs((points - centre) @ normal) <= WALL_BAND_M)
    if np.count_nonzero(on) < WALL_HITS:
        return None
    reach = (points[on] - centre) @ along
    if float(np.ptp(reach)) < WALL_SPAN_M:
        return None
    bow = np.polyfit(reach, (points[on] - centre) @ normal, 2)[0]
    if abs(bow) * float(np.ptp(reach) / 2) ** 2 > WALL_BOW_M:
        return None
    reach = np.sort(reach)
    breaks = np.flatnonzero(np.diff(reach) > WALL_GAP_M)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(reach) - 1]])
    span = float(np.max(reach[ends] - reach[starts]))
    if span < WALL_SPAN_M:
        return None
    return math.atan2(along[1], along[0]), span, on
