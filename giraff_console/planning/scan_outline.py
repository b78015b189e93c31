"""A range scan's free floor, as the map draws it (map_building.py, issue 29): which
beams it can use, and the outline of the floor they saw.

The outline is the polygon of the beams' ends round the robot, filled at once by the
map (cv2.fillPoly); where the beams have a gap (a blind sector, dropped readings) it is
split into fans from the robot (`fans`), so that the floor in the gap is left alone.
Where two neighbours' ranges step (a door's jamb, a wardrobe's corner) a corner is put
between them (`stepped`), and each hit's end is drawn a cell short of its surface,
measured across it (`short_of_hits`): the outline never runs along a wall's face, where
a few centimetres of pose error would clear the wall's cells scan after scan.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from giraff_console.protocol.kinematics import BODY_RADIUS_M

# Hits nearer than this are on the robot itself (its base is 0.6 m across; the sensor
# at its centre sees its own stalk and bumpers), and are not used.
MIN_RANGE_M = BODY_RADIUS_M
# Hits farther than this are treated as beams that met nothing: at 1 degree between
# beams they are 14 cm apart, and a small heading error moves them most.
MAX_HIT_M = 8.0
# A beam that met nothing clears the floor this far (or to range_max, if nearer): a dark
# or glancing surface beyond may have returned nothing.
CLEAR_NO_HIT_M = 4.0
# Neighbouring beams further apart than this leave the floor between them alone: a
# sensor's blind sector, or readings it dropped.
MAX_BEAM_GAP = math.radians(5.0)
# Neighbouring beams whose ranges differ by more than this share of the nearer (and at
# least MAX_DEPTH_STEP_M) end on two surfaces, one behind the other (`stepped`).
MAX_DEPTH_STEP, MAX_DEPTH_STEP_M = 0.2, 0.2
# A beam that meets its surface at a shallower angle than this is pulled back as if it
# met it at this one (`short_of_hits`): at most a cell over sin(8 degrees), 0.36 m; the
# floor that near a wall seen along it is left to other looks.
MIN_INCIDENCE = math.radians(8.0)
# A hit's surface runs from the hit this far round before it to as far after: two beams
# of a 360-beam sensor, more of a denser one (whose neighbours' ranges differ by less
# than their noise), at least SURFACE_SPAN_BEAMS.
SURFACE_SPAN, SURFACE_SPAN_BEAMS = math.radians(2.0), 2


def usable_beams(beams: Sequence[tuple[float, float]], range_max: float) -> tuple[np.ndarray, ...]:
    """A scan's beams in bearing order, those it can use: (distance to draw to, bearing,
    whether it ended on a hit). Readings of 0 or NaN (a sensor's "no reading") and hits
    on the robot itself are dropped; a beam that met nothing, or met it beyond
    MAX_HIT_M, is drawn to CLEAR_NO_HIT_M as free floor only."""
    table = np.asarray(beams, dtype=np.float64).reshape(-1, 2)
    distance, bearing = table[:, 0], table[:, 1]
    if not np.isfinite(bearing).all():
        raise ValueError("every beam's bearing must be a finite angle")
    clear = min(CLEAR_NO_HIT_M, range_max)
    hit = np.isfinite(distance) & (distance <= min(range_max, MAX_HIT_M))
    keep = (distance >= MIN_RANGE_M) & ~np.isnan(distance)
    distance = np.where(hit, distance, clear)[keep]
    bearing = np.mod(bearing[keep] + math.pi, math.tau) - math.pi
    order = np.argsort(bearing, kind="stable")
    return distance[order], bearing[order], hit[keep][order]


def short_of_hits(points: np.ndarray, hit: np.ndarray, length: np.ndarray,
                   bearing: np.ndarray, cell: float) -> np.ndarray:  # fmt: skip
    """How far the free floor reaches along each beam: a beam that met nothing to its
    end, a hit a `cell` short of its surface, measured across the surface.

    Pulled back a cell along the beam, a hit at a shallow angle stays on its wall: the
    polygon's edge from it to the next hit, tens of centimetres along the wall, then runs
    on the wall's face, and a few centimetres of pose error put it inside. Scan after
    scan, a wall seen edge-on from along a hall was cleared from both sides, the doorway
    beside it drawn twice its width and two rooms made one (tests/teaching's flat: the
    lounge's 0.8 m door mapped 1.45 m wide). So each hit is pulled back by a cell over the
    sine of the angle between its beam and the surface. The surface is the line through
    the hits SURFACE_SPAN either side of it (or the one side), every beam between them a
    hit on the same surface (no range step, no gap); a hit with neither side, or a scan
    too short to have sides, is taken as hit square on."""
    count = len(length)
    # The beams in SURFACE_SPAN (a millionth off, so that 2 degrees over 1 is 2, not 3).
    beams = math.ceil(SURFACE_SPAN / max(beam_spacing(bearing), 1e-9) - 1e-6)
    span = max(SURFACE_SPAN_BEAMS, beams)
    if count <= 2 * span:
        return np.where(hit, np.maximum(length - cell, 0.0), length)
    # Each beam and the next on one surface; a run of `span` of them either side, by
    # counting the breaks in a window (twice round, for the circle's wrap).
    joined = hit & np.roll(hit, -1) & ~range_steps(length) & (gaps(bearing) <= MAX_BEAM_GAP)
    breaks = np.concatenate([[0], np.cumsum(np.tile(~joined, 2))])
    index = np.arange(count)
    after = breaks[index + span] == breaks[index]
    before = breaks[index + count] == breaks[index + count - span]
    ahead = np.where(after[:, None], np.roll(points, -span, axis=0), points)
    behind = np.where(before[:, None], np.roll(points, span, axis=0), points)
    along = ahead - behind
    chord = np.hypot(along[:, 0], along[:, 1])
    across = np.abs(points[:, 0] * along[:, 1] - points[:, 1] * along[:, 0])
    # `length` is at least MIN_RANGE_M (`usable_beams`); a chord of 0 has no surface.
    sine = across / (length * np.where(chord > 0, chord, 1.0))
    sine = np.where(chord > 0, sine, 1.0)
    pull = cell / np.maximum(sine, math.sin(MIN_INCIDENCE))
    return np.where(hit, np.maximum(length - pull, 0.0), length)


def range_steps(ranges: np.ndarray) -> np.ndarray:
    """Whether each beam's range and the next's (the last's and the first's) step by
    more than MAX_DEPTH_STEP: two surfaces, one behind the other."""
    following = np.roll(ranges, -1)
    return np.abs(following - ranges) > np.maximum(
        MAX_DEPTH_STEP_M, MAX_DEPTH_STEP * np.minimum(ranges, following)
    )


def gaps(bearing: np.ndarray) -> np.ndarray:
    """The angle from each beam to the next, round the circle from the last to the first."""
    return np.diff(bearing, append=bearing[0] + math.tau)


def fans(corners: np.ndarray, centre: tuple[int, int], bearing: np.ndarray) -> list[np.ndarray]:
    """The polygons of free floor a scan's beam ends (`corners`, in bearing order) make:
    all of them, if no two neighbours are more than MAX_BEAM_GAP apart round the
    circle; otherwise a fan from the robot's `centre` for each run between gaps."""
    count = len(bearing)
    if count < 2:
        return []
    gap = gaps(bearing) > MAX_BEAM_GAP  # after each beam
    if not gap.any():
        return [corners]
    after = (int(np.argmax(gap)) + 1) % count  # start the circle just after a gap
    order = np.roll(np.arange(count), -after)
    runs = np.split(order, np.flatnonzero(gap[order][:-1]) + 1)
    return [np.vstack([centre, corners[run]]).astype(np.int32) for run in runs if len(run) > 1]


def stepped(reach: np.ndarray, bearing: np.ndarray,
             ranges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The free floor's outline, (distance, bearing) of each corner: the beams' ends
    (`reach` along each `bearing`), and where two neighbours' `ranges` step by more than
    MAX_DEPTH_STEP, a corner between them on the farther beam at the nearer one's reach.

    A step in range is an edge in the world (a door's jamb, a wardrobe's corner), and
    the straight line from the near end to the far one runs behind the near surface,
    often along a wall seen edge-on: filling up to it cleared that wall's cells scan
    after scan (a wall beside a doorway the robot drove past was lost). With the corner
    added the outline goes across the gap at the nearer range, then out along the
    farther beam, which is free floor."""
    if len(ranges) < 2:
        return reach, bearing
    following = np.roll(ranges, -1)
    step = range_steps(ranges)
    step[-1] = False  # the outline closes from the last beam to the first as it is
    after = np.flatnonzero(step)
    if not len(after):
        return reach, bearing
    nearer_first = ranges[after] < following[after]
    corner_bearing = np.where(nearer_first, bearing[after + 1], bearing[after])
    corner_reach = np.minimum(reach[after], reach[after + 1])
    at = after + 1  # inserted before the beam after the step
    return np.insert(reach, at, corner_reach), np.insert(bearing, at, corner_bearing)


def beam_spacing(bearing: np.ndarray) -> float:
    """The usual angle between neighbouring beams."""
    return float(np.median(np.diff(bearing))) if len(bearing) > 1 else math.tau
