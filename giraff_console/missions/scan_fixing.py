"""Where the range sensor says the robot is: each revolution fitted to the plan's map,
and the pose it fits at handed to the pose filter as a fix (issue 29; thesis §2.3,
§2.4).

A robot that has taught its building by driving it has a lidar and the map it made. The
markers correct the odometry only where the camera sees one (§2.6.3), and a survey
leaves some walls without any; the walls themselves are in every revolution. So, as
ROS robots do with AMCL, each revolution is matched against the plan's grid round the
pose the filter had when it was taken, by the mapping's own matcher
(planning/scan_matching.py), and the pose found corrects the filter
(robot/localisation.py's PoseFix), carried there to the present by the odometry. The
matcher searches only near the filter's pose, so a fix refines a pose somebody said; it
never places the robot (the localisation checks).

Why not every revolution
    Each match of the same walls repeats their errors (a wall drawn a few centimetres
    off is that far off in every scan of it), so fused at 5.5 a second the filter would
    soon believe itself to the millimetre and its gate refuse a marker that is right. A
    fix is taken after every FIX_EVERY_M or FIX_EVERY_TURN of the filter's pose, as
    AMCL's update_min_d and update_min_a, its noise is the map's, not the scan's, and
    the localisation fuses none into a pose already known better than the map
    (robot/localisation.py's SCAN_FLOOR_M).

The work is done on the fixer's own thread (revolution_queue.py), never the control
loop's: a match takes milliseconds. Of the revolutions that come while one is matched,
the newest waits.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from giraff_console.missions.mapping import StampedScan
from giraff_console.missions.pose_trail import REVOLUTION_S, PoseTrail
from giraff_console.missions.revolution_queue import RevolutionQueue
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.scan_matching import (
    COARSE_REACH_M,
    COARSE_TURN,
    MAX_COARSE_TURN,
    MIN_MAP_CELLS,
    USED,
    MatchOutcome,
    likelihood_field,
    match,
)
from giraff_console.planning.scan_outline import beam_spacing, usable_beams
from giraff_console.robot.localisation import PoseFix
from giraff_console.robot.odometry import Pose

# A fix after this much driving or turning since the last revolution fitted (above).
FIX_EVERY_M = 0.10
FIX_EVERY_TURN = math.radians(5.0)
# The least mean likelihood of a fix's hits on the map (loop_closure.py's LOOP_QUALITY):
# most of the hits on the map's walls. Furniture moved, people and open doors lower it.
FIX_QUALITY = 0.5
# A fix's standard deviations: the map's own error, not the matcher's step (0.025 m,
# 0.25 degrees). A map made by driving is off by 5-10 cm where its loops did not pull it
# in, and markers surveyed on it as far the other way: at 0.03 m and 1 degree, once a
# marker had fixed the pose the gate refused every fix (squared distances 15-100) and
# the robot, past the markers, was lost; at these a marker near by still outweighs them.
# Where the scan fits anywhere along a corridor (ACROSS_ONLY), it says nothing along it.
FIX_SIGMA_M = 0.07
FIX_SIGMA_RAD = math.radians(2.0)
ALONG_SIGMA_M = 1.0
# How far round the filter's heading the match looks: this many of the filter's
# heading standard deviations, and COARSE_TURN at least (the mapping's TURN_SIGMAS).
TURN_SIGMAS = 3.0
# A revolution is stamped when its last sample comes, but its samples were taken over
# the whole turn, and the pose it fits is where the robot was half way through (on the
# teaching drives the matched poses lag their stamps by 0.05 to 0.10 s, 2 to 3 cm at
# walking pace): a fix is timed at its middle. The turn's time is the time since the
# revolution before (a gap of more is a revolution missed); until there is one,
# pose_trail.py's REVOLUTION_S.
MAX_REVOLUTION_S = 0.5
# The map is matched in a window round the filter's pose: the hits' reach, the
# matcher's, and this much more.
WINDOW_MARGIN_M = 0.5


class ScanFixer:
    """Fits revolutions to the plan's map; safe to call from any thread."""

    def __init__(self, walls: Callable[[], OccupancyGrid | None],
                 fitted: Callable[[PoseFix], None],
                 note: Callable[[str], None] = lambda text: None) -> None:  # fmt: skip
        """`walls`: the grid to fit to now (None: fit nothing, as while mapping or
        surveying); `fitted`: hears each fix, on the fixer's thread; `note`: told if
        fitting stops."""
        self.walls = walls
        self.fitted = fitted
        self.note = note
        self.trail = PoseTrail()
        self.fixes = 0
        self._last: Pose | None = None  # the filter's pose at the last revolution fitted
        self._stamp: float | None = None  # the last revolution's, on the sensor's thread
        self._revolution_s = REVOLUTION_S
        self._queue: RevolutionQueue[tuple[StampedScan, float]] = RevolutionQueue(
            "scan fixes", 1, self._fitted, self._failed
        )

    def pose(self, time: float, pose: Pose, heading_sigma: float) -> None:
        """The filter's pose at `time` (the loop's clock): called every tick."""
        self.trail.add(time, pose, heading_sigma)

    def scan(self, scan: StampedScan) -> None:
        """A revolution, on the sensor's thread: queued, with the time of its middle,
        never waited on; one with samples lost (lidar/scan.py) is no fix, nor a measure
        of how long a turn takes."""
        if not scan.whole:
            return
        if self._stamp is not None and 0 < scan.taken_at - self._stamp <= MAX_REVOLUTION_S:
            self._revolution_s = scan.taken_at - self._stamp
        self._stamp = scan.taken_at
        self._queue.put((scan, scan.taken_at - self._revolution_s / 2))

    def close(self) -> None:
        self._queue.close()

    def fit(self, scan: StampedScan, middle: float) -> PoseFix | None:
        """The fix `scan`, taken round `middle`, gives, if it gives one, on the caller's
        thread (the fixer's own calls it for each revolution)."""
        grid = self.walls()
        prior = self.trail.at(middle)
        if (grid is None or prior is None or not scan.whole
                or self.trail.turning(scan.taken_at)):  # fmt: skip
            return None
        last = self._last
        if last is not None and (
            math.hypot(prior.x - last.x, prior.y - last.y) < FIX_EVERY_M
            and abs(math.remainder(prior.heading - last.heading, math.tau)) < FIX_EVERY_TURN
        ):
            return None
        distance, bearing, hit = usable_beams(scan.beams, float(scan.range_max))
        points = np.column_stack([distance * np.cos(bearing), distance * np.sin(bearing)])
        turns = TURN_SIGMAS * self.trail.heading_sigma(middle)
        self._last = prior
        reach = float(np.max(distance[hit], initial=0.0)) + COARSE_REACH_M + WINDOW_MARGIN_M
        occupied, left, top = grid.occupied_around(prior.x, prior.y, reach)
        if np.count_nonzero(occupied) < MIN_MAP_CELLS:
            return None
        field = likelihood_field(occupied, left, top, grid.resolution)
        found = match(field, prior, points[hit], beam_spacing(bearing), max(COARSE_TURN, turns))
        if found.outcome not in USED or found.quality < FIX_QUALITY:
            return None
        covariance = np.diag([FIX_SIGMA_M**2, FIX_SIGMA_M**2, FIX_SIGMA_RAD**2])
        if found.outcome is MatchOutcome.ACROSS_ONLY and found.along is not None:
            along = np.array(found.along)
            covariance[:2, :2] += (ALONG_SIGMA_M**2 - FIX_SIGMA_M**2) * np.outer(along, along)
        self.fixes += 1
        # Pinned: every way, and the heading searched as far as the filter says it may
        # be off (after a contact's pivot, further than the matcher looks).
        pinned = found.outcome is MatchOutcome.MATCHED and turns <= MAX_COARSE_TURN
        return PoseFix(middle, found.pose, covariance, pinned)

    def _fitted(self, queued: tuple[StampedScan, float]) -> None:
        fix = self.fit(*queued)
        if fix is not None:
            self.fitted(fix)

    def _failed(self) -> None:
        # A bug (logged): the robot goes on by its markers and odometry, as without a lidar.
        self.note("scan fixes stopped: an internal error (logged); the robot goes on by "
                  "its markers")  # fmt: skip
