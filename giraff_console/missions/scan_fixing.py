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
    fix is taken after every FIX_EVERY_M driven or FIX_EVERY_TURN turned, as AMCL's
    update_min_d and update_min_a, and its noise is the map's, not the scan's.

The work is done on the fixer's own thread (revolution_queue.py), never the control
loop's: a match takes milliseconds. Of the revolutions that come while one is matched,
the newest waits.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from giraff_console.missions.mapping import StampedScan
from giraff_console.missions.pose_trail import PoseTrail
from giraff_console.missions.revolution_queue import RevolutionQueue
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.planning.scan_matching import (
    COARSE_TURN,
    USED,
    LikelihoodField,
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
# A fix's standard deviations: the map's cells (0.05 m) and the matcher's finest step
# (0.025 m, 0.25 degrees) each way; where the scan fits anywhere along a corridor
# (ACROSS_ONLY), it says nothing along it.
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
# revolution before; until there is one, an RPLIDAR's 5.5 turns a second.
REVOLUTION_S = 1 / 5.5
MAX_REVOLUTION_S = 0.5


class ScanFixer:
    """Fits revolutions to the plan's map; safe to call from any thread."""

    def __init__(self, walls: Callable[[], OccupancyGrid | None],
                 fitted: Callable[[PoseFix], None]) -> None:  # fmt: skip
        """`walls`: the grid to fit to now (None: fit nothing, as while mapping);
        `fitted`: hears each fix, on the fixer's thread."""
        self.walls = walls
        self.fitted = fitted
        self.trail = PoseTrail()
        self.fixes = 0
        self._field: tuple[OccupancyGrid, LikelihoodField] | None = None
        self._last: Pose | None = None  # the filter's pose at the last revolution fitted
        self._stamp: float | None = None  # the last revolution's
        self._revolution_s = REVOLUTION_S
        self._queue = RevolutionQueue("scan fixes", 1, self._fitted, lambda: None)

    def pose(self, time: float, pose: Pose, heading_sigma: float) -> None:
        """The filter's pose at `time` (the loop's clock): called every tick."""
        self.trail.add(time, pose, heading_sigma)

    def scan(self, scan: StampedScan) -> None:
        """A whole revolution, on the sensor's thread: queued, never waited on."""
        if self._stamp is not None and 0 < scan.taken_at - self._stamp <= MAX_REVOLUTION_S:
            self._revolution_s = scan.taken_at - self._stamp
        self._stamp = scan.taken_at
        self._queue.put(scan)

    def close(self) -> None:
        self._queue.close()

    def fit(self, scan: StampedScan) -> PoseFix | None:
        """The fix `scan` gives, if it gives one, on the caller's thread (the fixer's
        own calls it for each revolution)."""
        grid = self.walls()
        middle = scan.taken_at - self._revolution_s / 2
        prior = self.trail.at(middle)
        if grid is None or prior is None or self.trail.turning(scan.taken_at):
            return None
        last = self._last
        if last is not None and (
            math.hypot(prior.x - last.x, prior.y - last.y) < FIX_EVERY_M
            and abs(math.remainder(prior.heading - last.heading, math.tau)) < FIX_EVERY_TURN
        ):
            return None
        distance, bearing, hit = usable_beams(scan.beams, float(scan.range_max))
        points = np.column_stack([distance * np.cos(bearing), distance * np.sin(bearing)])
        reach = max(COARSE_TURN, TURN_SIGMAS * self.trail.heading_sigma(middle))
        found = match(self._field_of(grid), prior, points[hit], beam_spacing(bearing), reach)
        self._last = prior
        if found.outcome not in USED or found.quality < FIX_QUALITY:
            return None
        covariance = np.diag([FIX_SIGMA_M**2, FIX_SIGMA_M**2, FIX_SIGMA_RAD**2])
        if found.outcome is MatchOutcome.ACROSS_ONLY and found.along is not None:
            along = np.array(found.along)
            covariance[:2, :2] += (ALONG_SIGMA_M**2 - FIX_SIGMA_M**2) * np.outer(along, along)
        self.fixes += 1
        return PoseFix(middle, found.pose, covariance)

    def _field_of(self, grid: OccupancyGrid) -> LikelihoodField:
        """The matcher's field of `grid`'s walls, made once for each grid."""
        if self._field is None or self._field[0] is not grid:
            rows = grid.cells.shape[0]
            top = grid.origin[1] + rows * grid.resolution
            made = likelihood_field(grid.cells == OCCUPIED, grid.origin[0], top, grid.resolution)
            self._field = (grid, made)
        return self._field[1]

    def _fitted(self, scan: StampedScan) -> None:
        # An exception here is a bug: logged, and the robot goes on by its markers and
        # odometry, as without a lidar.
        fix = self.fit(scan)
        if fix is not None:
            self.fitted(fix)
