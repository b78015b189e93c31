"""Teaching the building by driving it (issue 29; thesis §2.1, §2.6.3): the range
sensor's revolutions laid into an occupancy grid at the poses the filter gives, while
the operator drives, and the rooms named as the robot stands in them.

The thesis's ideal is a robot "driven once round by a person who names the rooms"
(§2.6.3) that builds the map it plans on itself (§2.1). Here the operator drives by
hand as ever; a mapping run only listens: every revolution the sensor completes is
placed at the pose the filter had when it was taken (missions/pose_trail.py) and laid
into the grid by the map builder (planning/map_building.py), which matches it against
the map so far where that helps and keeps the correction it found. `mark NAME` notes
where the robot stands, in the corrected frame, for the room there to take NAME when
the plan is written (planning/mapped_plan.py).

The work is done on the run's own thread (revolution_queue.py), never the control
loop's: a revolution takes milliseconds to lay in, and the loop must tick on time
whatever the sensor sends (design.md).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from giraff_console.missions.lookout import Scan
from giraff_console.missions.pose_trail import PoseTrail
from giraff_console.missions.revolution_queue import RevolutionQueue
from giraff_console.planning.floorplan import Point
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.loop_closure import Closed, close_loops, moved, redrawn
from giraff_console.planning.map_building import (
    MAX_KEPT_BYTES,
    Correction,
    MapBuilder,
    MapTooLarge,
)
from giraff_console.planning.scan_matching import COARSE_TURN
from giraff_console.robot.odometry import Pose

log = logging.getLogger(__name__)

# Revolutions waiting to be laid in: the newest few; older ones are dropped.
MAX_WAITING = 4
# The matcher searches round the filter's heading three of the filter's standard
# deviations of what the heading may have turned, unseen, since the last revolution
# (the casters after a turn on the spot, §3.2.1.5), and COARSE_TURN at least.
TURN_SIGMAS = 3.0


class StampedScan(Scan, Protocol):
    """A whole revolution, with the time its last sample came (the loop's clock)."""

    @property
    def taken_at(self) -> float: ...


@dataclass(frozen=True)
class MapMark:
    """`mark NAME` while mapping: the room where the robot stood is NAME."""

    name: str
    at: Point  # the map's frame
    laid: int = 0  # how many revolutions were laid in when it was marked


@dataclass(frozen=True)
class MappingStatus:
    """How a mapping run is going, for `status` and the screen."""

    scans: int  # revolutions laid into the grid
    dropped: int  # revolutions that came faster than they could be laid in
    unplaced: int  # revolutions too old or too new for the trail's poses
    turning: int  # revolutions taken while the robot turned, left out
    broken: int  # revolutions with samples lost (a reader that fell behind), left out
    marks: tuple[MapMark, ...]


class MappingRun:
    """One drive through the building, mapped; safe to call from any thread."""

    def __init__(self, builder: MapBuilder, note: Callable[[str], None], start: Pose, *,
                 after: Callable[[MappingRun], None] = lambda run: None) -> None:  # fmt: skip
        """`start`: where the robot stood when mapping began (the map's dock). `after`
        is called on the run's thread after each revolution laid in."""
        self.builder = builder
        self.start = start
        self.note = note
        self.after = after
        self.trail = PoseTrail()
        self._lock = threading.Lock()
        # The builder's grid grows on this run's thread; it is read on others.
        self._building = threading.Lock()
        self._marks: dict[str, MapMark] = {}
        self._scans = self._unplaced = self._turning = self._broken = 0
        self._sigma: float | None = None  # the heading's, at the last revolution laid in
        self._queue = RevolutionQueue("mapping", MAX_WAITING, self._laid_in, self._failed)

    # -- fed by the loop and the sensor ----------------------------------------------

    def pose(self, time: float, pose: Pose, heading_sigma: float) -> None:
        """The filter's pose at `time` (the loop's clock), and its heading's standard
        deviation: called every tick."""
        self.trail.add(time, pose, heading_sigma)

    def scan(self, scan: StampedScan) -> None:
        """A revolution, on the sensor's thread: queued, never waited on; one with
        samples lost is counted and left out at once, so that it takes no whole one's
        place in the queue."""
        if not self._left_out(scan):
            self._queue.put(scan)

    # -- asked by the service ------------------------------------------------------

    def mark(self, name: str, pose: Pose) -> MapMark:
        """The room where the robot stands (the filter's `pose`) is `name`; a second
        mark of the same name moves it."""
        with self._building:
            corrected = self.builder.correction.apply(pose)
            laid = len(self.builder.laid)
        mark = MapMark(name, (corrected.x, corrected.y), laid)
        with self._lock:
            self._marks[name] = mark
        return mark

    def corrected(self, pose: Pose) -> Pose:
        """The filter's `pose` in the map's frame, as scan matching has corrected it."""
        with self._building:
            return self.builder.correction.apply(pose)

    def close_loops(self) -> Closed | None:
        """Correct the map where the drive came back to places it had seen
        (planning/loop_closure.py): the revolutions drawn again at the poses corrected,
        the marks moved with them, and the filter's poses carried into the corrected
        frame from here on. None if the builder keeps no revolutions. Seconds of work,
        on the caller's thread; the run's thread waits meanwhile (revolutions that come
        are dropped, counted)."""
        with self._building:
            old = self.builder
            if not old.keep or not old.laid:
                return None
            laid = list(old.laid)
            closed = close_loops(laid, old.resolution)
            if not closed.corrected:
                return closed
            builder = redrawn(laid, closed.poses, old.resolution)
            builder.match_scans = old.match_scans
            builder.restamp(laid[-1].stamp)
            builder.correction = Correction.between(laid[-1].filtered, closed.poses[-1])
            self.builder = builder
        with self._lock:
            for name, mark in self._marks.items():
                if 0 < mark.laid <= len(laid):
                    at = moved(mark.at, laid[mark.laid - 1].pose, closed.poses[mark.laid - 1])
                    self._marks[name] = MapMark(name, at, mark.laid)
        return closed

    def status(self) -> MappingStatus:
        with self._lock:
            return MappingStatus(self._scans, self._queue.dropped, self._unplaced, self._turning,
                                 self._broken, tuple(self._marks.values()))  # fmt: skip

    def grid(self) -> OccupancyGrid:
        """The map so far."""
        with self._building:
            return self.builder.grid()

    def close(self) -> None:
        """Stop laying revolutions in; what is laid in stays."""
        self._queue.close()

    # -- the run's thread ------------------------------------------------------------

    def _left_out(self, scan: StampedScan) -> bool:
        """Whether `scan` has samples lost (counted if so). A piece of a turn, or two
        run together: drawn at one pose it smears the walls, and matched it may jump
        the map's pose (in a recorded teaching drive, bench/teach_replay.py, a piece of
        76 samples moved it 0.33 m)."""
        if scan.whole:
            return False
        with self._lock:
            self._broken += 1
        return True

    def _laid_in(self, scan: StampedScan) -> None:
        self.lay_in(scan)
        try:
            self.after(self)
        except Exception:
            # The screens' picture failed (a listener's bug): the map grows on.
            log.exception("mapping: telling of the map failed")

    def _failed(self) -> None:
        # A bug: the map stops growing, and the operator is told; the robot drives on as
        # before, since mapping only listens.
        self.note("mapping stopped: an internal error (logged); `map save NAME` keeps what "
                  "was mapped")  # fmt: skip

    def lay_in(self, scan: StampedScan) -> None:
        """Lay `scan` into the map now, on the caller's thread: the run's thread does,
        for each revolution it is given; a drive replayed (bench/teach_replay.py) calls
        it in turn, none dropped."""
        if self._left_out(scan):
            return
        stamp = scan.taken_at
        pose = self.trail.at(stamp)
        if pose is None:
            with self._lock:
                self._unplaced += 1
            return
        if self.trail.turning(stamp):
            # Smeared: the turn itself is the wheels' to measure, which they do well on
            # the spot (§3.2.1.5: it is the casters afterwards).
            with self._lock:
                self._turning += 1
            return
        sigma = self.trail.heading_sigma(stamp)
        # The heading's variance grows by what it may have turned since the last one.
        grown = math.sqrt(max(0.0, sigma**2 - self._sigma**2)) if self._sigma is not None else 0.0
        self._sigma = sigma
        try:
            with self._building:
                keeping = self.builder.keep
                self.builder.add(pose, scan, stamp, max(COARSE_TURN, TURN_SIGMAS * grown))
                stopped_keeping = keeping and not self.builder.keep
        except MapTooLarge as error:
            self.note(f"mapping stopped: {error}; `map save NAME` keeps what was mapped")
            self._queue.stop()
            return
        except ValueError:
            # A revolution the builder cannot use (one stamped before the last): dropped.
            with self._lock:
                self._unplaced += 1
            return
        if stopped_keeping:
            self.note(f"mapping: the drive is longer than loop closure keeps "
                      f"({MAX_KEPT_BYTES // 2**20} MB of revolutions, about 80 minutes); "
                      "the map is saved as drawn")  # fmt: skip
        with self._lock:
            self._scans += 1
