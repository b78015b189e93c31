"""The map built while the operator drives: an occupancy grid from range scans (issue 29).

The thesis's robot learns its building by being driven round it once (§2.1, §2.6.3),
and holds what it learns as a grid of free, occupied and unexplored cells (§2.6.4).
Each scan, at the pose the filter gives and the scan matcher corrects
(scan_matching.py), says two things: the floor between the robot and each hit is free,
and the hit is an obstacle. Both are evidence, not fact (a person walks past, a beam
glances off glass), so each cell keeps the log-odds of being occupied, in hundredths,
bounded so that something taken away is forgotten after a few seconds of seeing
through it, but a wall seen well is not redrawn by a pose gone a little astray; its
state is read by map_server's own thresholds (occupied above p = 0.65, free below
0.196).

The free space of a scan is the outline of the floor it saw (scan_outline.py), filled
at once (cv2.fillPoly): the same cells as a line per beam, in one call.

The grid grows as the robot explores, in whole chunks, up to MAX_CELLS: a building
larger than that is refused with a MapTooLarge before anything is allocated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.planning.scan_matching import (
    COARSE_REACH_M,
    COARSE_TURN,
    FINE_REACH_M,
    FINE_TURN,
    MAX_COARSE_TURN,
    MIN_HITS,
    MIN_MAP_CELLS,
    USED,
    Match,
    MatchOutcome,
    likelihood_field,
    match,
)
from giraff_console.planning.scan_outline import (
    beam_spacing,
    fans,
    short_of_hits,
    stepped,
    usable_beams,
)
from giraff_console.protocol.kinematics import BODY_RADIUS_M
from giraff_console.robot.odometry import Pose

RESOLUTION_M = 0.05
# The grid grows by chunks of this many cells a side (8 m at 0.05 m), aligned to the
# map frame, so that a robot driving along grows it a few times, not at every scan.
CHUNK_CELLS = 160
# The most cells a map may hold: a 300 x 150 m airport at 0.05 m with 10 m round it
# (320 x 170 m), 3 bytes a cell (log-odds and state): 72 MB.
MAX_CELLS = 6400 * 3400
# The bytes of scans a builder that keeps them (`keep`, for loop closure) holds at most:
# a revolution of 360 beams is 4.7 kB, so about 80 minutes of a 5.5 Hz sensor (the
# home's teaching drive, 11 minutes, kept 17 MB).
MAX_KEPT_BYTES = 128 * 1024 * 1024
# The most beams a scan may have: an RPLIDAR's densest mode gives about 1600 a turn.
MAX_BEAMS = 8192
# Log-odds in hundredths: a hit, a beam through, and their bound. One hit makes a cell
# occupied; four beams through it make it free. A miss weighs less than a hit because a
# wall's cells are grazed by beams drawn at poses a few centimetres off: at -75 a miss,
# the care-home wing's drive showed 3 % less of its walls (tests/mapping). The bound is
# how long a wall is remembered: a cell hit 12 times or more is no obstacle once 24
# revolutions have seen through it (4.4 s of the sensor's), and free after 29 (a trolley
# moved away while mapping). At 400 (9 revolutions) the map followed the pose: a wall
# first seen well was drawn again, and replaced, by revolutions at a pose a degree off,
# and the drift stayed (a corridor drawn 1 degree tilted on a recorded home drive). At
# 1000, over 24 replays of four recorded drives (docs/performance.md), the worst room's
# walls came out 0.098 m off on average, not 0.132, and 95.5 % of the map within 0.10 m,
# not 94.7.
HIT, MISS, BOUND = 90, -40, 1000
# map_server's thresholds as log-odds: ln(0.65 / 0.35) and ln(0.196 / 0.804).
OCCUPIED_ABOVE = round(100 * math.log(0.65 / 0.35))
FREE_BELOW = round(100 * math.log(0.196 / 0.804))
# The grid is cropped to what was seen and this much round it.
CROP_MARGIN_M = 0.5
# The matcher moves the robot at most this far (its lattices' corners, and a cell); a
# turn moves a hit along its circle round the robot, at most its distance times the turn.
_SEARCH_M = math.sqrt(2) * (COARSE_REACH_M + FINE_REACH_M) + 0.05
# Each log-odds' state, looked up at once: index by log-odds + BOUND.
_STATES = np.full(2 * BOUND + 1, UNKNOWN, dtype=np.uint8)
_STATES[BOUND + OCCUPIED_ABOVE + 1 :] = OCCUPIED
_STATES[: BOUND + FREE_BELOW] = FREE
_SHIFT = 4  # fillPoly's fixed-point bits: beam ends placed to a sixteenth of a cell


class RangeScan(Protocol):
    """One sweep of a range finder, as a LIDAR's scan message has it: each beam's
    (distance m, bearing rad, positive to the left) in the robot's frame; a distance of
    `math.inf` (ROS REP 117) says the beam met nothing within `range_max`."""

    @property
    def range_max(self) -> float: ...

    @property
    def beams(self) -> Sequence[tuple[float, float]]: ...


class MapTooLarge(ValueError):
    """The map would hold more than MAX_CELLS; the message says how large it would be."""


@dataclass(frozen=True)
class Correction:
    """The rigid move taking the pose filter's frame onto the map's: the map's pose of
    the robot is `apply(filter's pose)`."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0

    def apply(self, pose: Pose) -> Pose:
        c, s = math.cos(self.heading), math.sin(self.heading)
        return Pose(self.x + c * pose.x - s * pose.y, self.y + s * pose.x + c * pose.y,
                    pose.heading + self.heading)  # fmt: skip

    @classmethod
    def between(cls, filtered: Pose, mapped: Pose) -> Correction:
        """The correction that takes `filtered` onto `mapped`."""
        turn = mapped.heading - filtered.heading
        c, s = math.cos(turn), math.sin(turn)
        return cls(mapped.x - (c * filtered.x - s * filtered.y),
                   mapped.y - (s * filtered.x + c * filtered.y), turn)  # fmt: skip


@dataclass(frozen=True)
class MatchedPose:
    """What `add` did with one scan."""

    stamp: float
    filtered: Pose  # the pose filter's pose, as given
    prior: Pose  # that pose under the correction before this scan
    pose: Pose  # the pose the scan was drawn at
    outcome: MatchOutcome
    quality: float  # the hits' mean likelihood at `pose`, 0 to 1 (0: not matched)

    @property
    def matched(self) -> bool:
        """Whether the scan matcher's pose was used, in full or across a corridor."""
        return self.outcome in USED

    @property
    def shift_m(self) -> float:
        """How far the match moved the pose from `prior`."""
        return math.hypot(self.pose.x - self.prior.x, self.pose.y - self.prior.y)

    @property
    def turn_rad(self) -> float:
        """How far the match turned it, signed."""
        return math.remainder(self.pose.heading - self.prior.heading, math.tau)


@dataclass(frozen=True)
class Laid:
    """One scan as it was drawn, kept for the map to be drawn again at corrected poses
    (loop_closure.py): its stamp, the filter's pose and the pose drawn at, and its beams
    in the robot's frame (where each was drawn to, float32; whether it ended on a hit;
    its bearing)."""

    stamp: float
    filtered: Pose
    pose: Pose
    points: np.ndarray
    hit: np.ndarray
    bearing: np.ndarray

    @property
    def hits(self) -> np.ndarray:
        return np.asarray(self.points[self.hit], dtype=np.float64)


@dataclass(frozen=True)
class MapView:
    """The map as it stands, to draw: cells FREE, OCCUPIED or UNKNOWN (read-only, row 0
    at the top), placed as an OccupancyGrid's; `revision` changes with every scan."""

    cells: np.ndarray
    origin: tuple[float, float]
    resolution: float
    revision: int


class MapBuilder:
    """An occupancy grid built from range scans at the pose filter's poses."""

    def __init__(self, resolution: float = RESOLUTION_M, match_scans: bool = True,
                 keep: bool = False) -> None:  # fmt: skip
        """`keep`: each scan drawn is kept (`laid`), to draw the map again."""
        if not (math.isfinite(resolution) and 0.005 <= resolution <= 1.0):
            raise ValueError(f"resolution should be 0.005 to 1 m, not {resolution}")
        self.resolution = resolution
        self.match_scans = match_scans
        self.keep = keep
        self.laid: list[Laid] = []
        self._kept_bytes = 0
        self.correction = Correction()
        self.revision = 0
        self._odds = np.zeros((0, 0), dtype=np.int16)
        self._states = np.zeros((0, 0), dtype=np.uint8)
        self._left = self._bottom = 0  # the map-frame cell index of column 0, of the last row
        self._stamp = -math.inf
        self._view: MapView | None = None

    def add(self, pose: Pose, scan: RangeScan, stamp: float,
            turn_reach: float = COARSE_TURN) -> MatchedPose:  # fmt: skip
        """Draw `scan`, taken at the filter's `pose` at `stamp` (seconds, not earlier
        than the last), at the pose the scan matcher finds for it; ValueError for a pose,
        scan or stamp that cannot be used, MapTooLarge if the map would outgrow
        MAX_CELLS (the map is then as it was)."""
        if not all(map(math.isfinite, (pose.x, pose.y, pose.heading, stamp))):
            raise ValueError(f"the pose and stamp must be finite, not {pose} at {stamp}")
        if stamp < self._stamp:
            raise ValueError(f"scan at {stamp} s is older than the last one ({self._stamp} s)")
        range_max = float(scan.range_max)
        if not (math.isfinite(range_max) and range_max > 0):
            raise ValueError(f"range_max should be a positive distance, not {range_max}")
        if len(scan.beams) > MAX_BEAMS:
            raise ValueError(f"a scan of {len(scan.beams)} beams: at most {MAX_BEAMS}")
        distance, bearing, hit = usable_beams(scan.beams, range_max)
        prior = self.correction.apply(pose)
        reach = float(np.max(distance, initial=0.0))
        # Wherever the matcher puts the robot, its hits and footprint are on the grid.
        self._cover(prior, reach + _SEARCH_M + BODY_RADIUS_M)
        points = np.column_stack([distance * np.cos(bearing), distance * np.sin(bearing)])
        found = self._match(prior, points[hit], beam_spacing(bearing), reach, turn_reach)
        self.correction = Correction.between(pose, found.pose)
        self._draw(found.pose, points, hit, bearing)
        self._stamp = stamp
        self.revision += 1
        self._keep(Laid(stamp, pose, found.pose, points.astype(np.float32), hit,
                        bearing.astype(np.float32)))  # fmt: skip
        return MatchedPose(stamp, pose, prior, found.pose, found.outcome, found.quality)

    def draw_laid(self, laid: Laid, pose: Pose) -> None:
        """Draw a scan kept by another builder at `pose`, unmatched (the map drawn again
        at poses a loop closure corrected)."""
        points = np.asarray(laid.points, dtype=np.float64)
        bearing = np.asarray(laid.bearing, dtype=np.float64)
        reach = float(np.max(np.hypot(points[:, 0], points[:, 1]), initial=0.0))
        self._cover(pose, reach + BODY_RADIUS_M + self.resolution)
        self._draw(pose, points, laid.hit, bearing)
        self.revision += 1
        self._keep(Laid(laid.stamp, laid.filtered, pose, laid.points, laid.hit, laid.bearing))

    def _keep(self, laid: Laid) -> None:
        """Keep `laid`, if this builder keeps its scans and has room for one more; a
        drive that would take more than MAX_KEPT_BYTES keeps none (issue 30: every input
        bounded)."""
        if not self.keep:
            return
        size = laid.points.nbytes + laid.hit.nbytes + laid.bearing.nbytes
        if self._kept_bytes + size > MAX_KEPT_BYTES:
            self.keep, self.laid, self._kept_bytes = False, [], 0
            return
        self.laid.append(laid)
        self._kept_bytes += size

    def restamp(self, stamp: float) -> None:
        """The next scan may not be older than `stamp` (a map drawn again)."""
        self._stamp = max(self._stamp, stamp)

    def occupied_window(self) -> tuple[np.ndarray, float, float]:
        """The grid's occupied cells, and the map (left, top) of its top-left corner."""
        return self._odds > OCCUPIED_ABOVE, self._left * self.resolution, self._top()

    def view(self) -> MapView:
        """The map to draw; the same object until the next scan, so a screen that
        keeps the last one redraws only on change."""
        if self._view is None or self._view.revision != self.revision:
            cells = self._states.copy()
            cells.setflags(write=False)
            self._view = MapView(cells, self._origin(), self.resolution, self.revision)
        return self._view

    def grid(self) -> OccupancyGrid:
        """The map as an OccupancyGrid, cropped to the cells seen and CROP_MARGIN_M
        round them (the whole grid, unknown, if nothing has been seen)."""
        seen = self._states != UNKNOWN
        rows, cols = np.flatnonzero(seen.any(axis=1)), np.flatnonzero(seen.any(axis=0))
        if not len(rows):
            return OccupancyGrid(self._states.copy(), self.resolution, self._origin())
        margin = math.ceil(CROP_MARGIN_M / self.resolution)
        height, width = self._states.shape
        top, bottom = max(0, rows[0] - margin), min(height, rows[-1] + 1 + margin)
        left, right = max(0, cols[0] - margin), min(width, cols[-1] + 1 + margin)
        origin = ((self._left + left) * self.resolution,
                  (self._bottom + height - bottom) * self.resolution)  # fmt: skip
        return OccupancyGrid(self._states[top:bottom, left:right].copy(), self.resolution, origin)

    def _origin(self) -> tuple[float, float]:
        return self._left * self.resolution, self._bottom * self.resolution

    def _top(self) -> float:
        """The map-frame y of the grid's top edge."""
        return (self._bottom + self._odds.shape[0]) * self.resolution

    def _cover(self, centre: Pose, reach: float) -> None:
        """Grow the grid, by whole chunks, to hold the disc of `reach` round `centre`."""
        res = self.resolution
        left = math.floor((centre.x - reach) / res)
        right = math.floor((centre.x + reach) / res) + 1
        bottom = math.floor((centre.y - reach) / res)
        top = math.floor((centre.y + reach) / res) + 1
        height, width = self._odds.shape
        if width and (left >= self._left and right <= self._left + width
                      and bottom >= self._bottom and top <= self._bottom + height):  # fmt: skip
            return
        if width:
            left, bottom = min(left, self._left), min(bottom, self._bottom)
            right, top = max(right, self._left + width), max(top, self._bottom + height)
        wanted = (left, bottom, right, top)
        chunked = (
            CHUNK_CELLS * math.floor(left / CHUNK_CELLS),
            CHUNK_CELLS * math.floor(bottom / CHUNK_CELLS),
            CHUNK_CELLS * math.ceil(right / CHUNK_CELLS),
            CHUNK_CELLS * math.ceil(top / CHUNK_CELLS),
        )
        for left, bottom, right, top in (chunked, wanted):
            if (right - left) * (top - bottom) <= MAX_CELLS:
                break
        else:
            raise MapTooLarge(
                f"the map would be {(right - left) * res:.0f} x {(top - bottom) * res:.0f} m "
                f"({(right - left) * (top - bottom):,} cells at {res:g} m): a map holds at "
                f"most {MAX_CELLS:,} cells, a 320 x 170 m building at 0.05 m"
            )
        odds = np.zeros((top - bottom, right - left), dtype=np.int16)
        states = np.full(odds.shape, UNKNOWN, dtype=np.uint8)
        if width:
            # Row 0 is the top: the old grid sits (new top - old top) rows down.
            down = top - (self._bottom + height)
            across = self._left - left
            odds[down : down + height, across : across + width] = self._odds
            states[down : down + height, across : across + width] = self._states
        self._odds, self._states = odds, states
        self._left, self._bottom = left, bottom

    def _match(self, prior: Pose, points: np.ndarray, spacing: float, reach: float,
               turn_reach: float) -> Match:  # fmt: skip
        """The matcher's pose for the hits `points` (robot frame), on the map's cells
        round every pose it may try."""
        if not self.match_scans:
            return Match(MatchOutcome.MATCHING_OFF, prior, 0.0)
        if len(points) < MIN_HITS:
            return Match(MatchOutcome.TOO_FEW_HITS, prior, 0.0)
        c, s = math.cos(prior.heading), math.sin(prior.heading)
        xs = prior.x + c * points[:, 0] - s * points[:, 1]
        ys = prior.y + s * points[:, 0] + c * points[:, 1]
        turn = min(max(turn_reach, COARSE_TURN), MAX_COARSE_TURN) + FINE_TURN
        rows, cols = self._window(xs, ys, _SEARCH_M + reach * turn)
        occupied = self._odds[rows, cols] > OCCUPIED_ABOVE
        if np.count_nonzero(occupied) < MIN_MAP_CELLS:
            return Match(MatchOutcome.MAP_TOO_SPARSE, prior, 0.0)
        left = (self._left + cols.start) * self.resolution
        top = self._top() - rows.start * self.resolution
        return match(likelihood_field(occupied, left, top, self.resolution), prior, points,
                     spacing, turn_reach)  # fmt: skip

    def _window(self, xs: np.ndarray, ys: np.ndarray, margin: float) -> tuple[slice, slice]:
        """The rows and columns of the grid holding the points and `margin` round them."""
        res, (height, width) = self.resolution, self._odds.shape
        left = math.floor((float(xs.min()) - margin) / res) - self._left
        right = math.floor((float(xs.max()) + margin) / res) + 1 - self._left
        top = math.floor((self._top() - float(ys.max()) - margin) / res)
        bottom = math.floor((self._top() - float(ys.min()) + margin) / res) + 1
        return (slice(max(0, top), min(height, bottom)), slice(max(0, left), min(width, right)))

    def _draw(self, pose: Pose, points: np.ndarray, hit: np.ndarray, bearing: np.ndarray) -> None:
        """Put one scan, at `pose`, into the log-odds and the states of the cells it saw."""
        c, s = math.cos(pose.heading), math.sin(pose.heading)
        length = np.hypot(points[:, 0], points[:, 1])
        short = short_of_hits(points, hit, length, bearing, self.resolution)
        reach, bearing = stepped(short, bearing, length)
        fx, fy = reach * np.cos(bearing), reach * np.sin(bearing)
        xs = np.append(pose.x + c * fx - s * fy, pose.x)
        ys = np.append(pose.y + s * fx + c * fy, pose.y)
        hx = pose.x + c * points[hit, 0] - s * points[hit, 1]
        hy = pose.y + s * points[hit, 0] + c * points[hit, 1]
        # Round the outline, the robot's footprint and the hits (up to 0.36 m beyond it).
        rows, cols = self._window(np.append(xs, hx), np.append(ys, hy),
                                  BODY_RADIUS_M + self.resolution)  # fmt: skip
        delta = np.zeros((rows.stop - rows.start, cols.stop - cols.start), dtype=np.int16)
        left = (self._left + cols.start) * self.resolution
        top = self._top() - rows.start * self.resolution
        one = 1 << _SHIFT
        u = np.round((xs - left) / self.resolution * one - one / 2).astype(np.int32)
        v = np.round((top - ys) / self.resolution * one - one / 2).astype(np.int32)
        centre = (int(u[-1]), int(v[-1]))
        corners = np.column_stack([u[:-1], v[:-1]])
        cv2.fillPoly(delta, fans(corners, centre, bearing), MISS, lineType=cv2.LINE_8,
                     shift=_SHIFT)  # fmt: skip
        # The robot stands on its own footprint: that floor is free.
        radius = round(BODY_RADIUS_M / self.resolution * one)
        cv2.circle(delta, centre, radius, MISS, thickness=-1, lineType=cv2.LINE_8, shift=_SHIFT)
        hit_cols = np.floor((hx - left) / self.resolution).astype(np.intp)
        hit_rows = np.floor((top - hy) / self.resolution).astype(np.intp)
        delta[hit_rows, hit_cols] = HIT
        odds = self._odds[rows, cols]
        np.add(odds, delta, out=odds)
        np.clip(odds, -BOUND, BOUND, out=odds)
        self._states[rows, cols] = _STATES[odds + BOUND]
