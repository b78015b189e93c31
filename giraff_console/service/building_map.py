"""Mapping for the robot service (issue 29): `map`, `mark ROOM`, `map save NAME`,
`map discard`, whoever types them (a console, the daemon's, `giraff-console send`).

A mapping run (missions/mapping.py) hears the range sensor's revolutions and the
loop's poses; the screens are shown the map as it grows, at most once a second and
small enough to cross the daemon's socket (`MapDrawn`). Saving writes the map and the
floor plan made from it (planning/mapped_plan.py) and makes that plan the one the
robot plans on at once: the navigator's, and every front end's (`PlanChanged`). The
robot is then placed where the run's scan matching put it, so that the pose and the
new plan agree (the filter alone drifts from the map as the run goes on, §2.3).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from giraff_console.missions.mapping import MappingRun, StampedScan
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.map_building import MapBuilder
from giraff_console.planning.mapped_plan import MappedPlanError, write_mapped_plan
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.localisation import PoseBasis
from giraff_console.robot.loop_events import LoopEvent
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service.events import MapDrawn, PlanChanged, Reply, RouteShown

log = logging.getLogger(__name__)

# The picture the screens are shown: at most this many cells a side (coarser cells
# for a bigger map), and no more often than every DRAWN_EVERY_S.
MAP_PICTURE_CELLS = 600
DRAWN_EVERY_S = 1.0
# Seconds `map save` waits for the loop to place the robot on the new map (a tick).
PLACED_WITHIN_S = 2.0
# map_server's trinary pixels (planning/ros_map.py reads them back).
_PIXEL_FREE, _PIXEL_OCCUPIED, _PIXEL_UNKNOWN = 254, 0, 205


class ScanSource(Protocol):
    """A range sensor that hands out its whole revolutions, each stamped with the time
    it ended on the control loop's clock."""

    def subscribe(self, listener: Callable[[StampedScan], None]) -> None: ...
    def unsubscribe(self, listener: Callable[[StampedScan], None]) -> None: ...


Tell = Callable[[MapDrawn | PlanChanged | RouteShown], None]


class BuildingMap:
    """At most one mapping run at a time; safe to call from any thread."""

    def __init__(self, control: ControlLoop, navigator: Navigator | None,
                 sensor: ScanSource | None, tell: Tell) -> None:  # fmt: skip
        self.control = control
        self.navigator = navigator
        self.sensor = sensor
        self.tell = tell
        self.run: MappingRun | None = None
        # Held by each request to the end: a `map discard` from one console never falls
        # between another's `mark` or `map save` looking at the run and using it.
        self._lock = threading.RLock()
        self._drawn_at = -math.inf
        self._drawn_revision = -1

    @property
    def mapping(self) -> bool:
        return self.run is not None

    def start(self) -> Reply:
        if self.sensor is None:
            return Reply(False, "map: no range sensor: set [lidar] port in the settings, "
                                "or --lidar PORT (with --sim, --lidar alone simulates "
                                "one)")  # fmt: skip
        if self.navigator is None:
            return Reply(False, "map: no floor plan to start from (--floorplan FILE)")
        with self._lock:
            if self.run is not None:
                return Reply(False, "map: mapping already; `map save NAME` or `map discard`")
            self._drawn_at, self._drawn_revision = -math.inf, -1
            # Where mapping starts is the map's dock: the plan made starts there.
            run = self.run = MappingRun(MapBuilder(keep=True), self.control.note,
                                        self.control.pose, after=self._laid_in)  # fmt: skip
            self.control.subscribe(self._heard)
            self.sensor.subscribe(run.scan)
        return Reply(True, "mapping: drive through every room, and type `mark ROOM` in each; "
                           "`map save NAME` when done")  # fmt: skip

    def mark(self, name: str) -> Reply:
        with self._lock:
            run = self.run
            if run is None:
                return Reply(False, "mark: mapping has ended")
            mark = run.mark(name, self.control.pose)
        return Reply(True, f"marked {name} at ({mark.at[0]:.2f}, {mark.at[1]:.2f}): the room "
                           "here takes the name when the map is saved")  # fmt: skip

    def save(self, to: Path) -> Reply:
        if not to.is_absolute():
            # A daemon's folder is not the console's: the console resolves what is typed.
            return Reply(False, f"map save: {to} is not a whole path")
        with self._lock:
            return self._save(to)

    def _save(self, to: Path) -> Reply:
        run, navigator = self.run, self.navigator
        if run is None or navigator is None:
            return Reply(False, "map save: not mapping (`map` starts)")
        if self.control.mission is not None or self.control.missions_starting:
            return Reply(False, "map save: not while a mission runs; stop it first")
        status = run.status()
        if not status.scans:
            return Reply(False, "map save: nothing mapped yet: is the range sensor turning?")
        # Where the drive came back to places it had seen, the map is drawn again at
        # the poses those say (planning/loop_closure.py), and the marks moved with it.
        run.close_loops()
        status = run.status()
        try:
            marks = [(mark.name, mark.at) for mark in status.marks]
            made = write_mapped_plan(run.grid(), marks, run.start, to)
            walls = walls_of(made.plan)
        except MappedPlanError as error:
            return Reply(False, f"map save: nothing written: {error}; still mapping")
        except OSError as error:  # the grid just written cannot be read back
            return Reply(False, f"map save: {made.plan.path} written, but its grid cannot "
                                f"be read: {error.strerror or 'unreadable'}; still "
                                "mapping")  # fmt: skip
        self._end(run)
        navigator.use_building(made.plan, walls)
        control = self.control
        localisation = control.localisation

        done = threading.Event()

        def placed() -> None:
            # Where the map has the robot, as of this tick; and no markers of the old plan
            # (a survey finds the new plan's), which would pull it back to the old frame.
            localisation.use_markers({}, localisation.marker_size)
            control.place(run.corrected(control.pose), PoseBasis.GIVEN)
            done.set()

        control.between_ticks(placed)
        # Answered once the robot stands where the map has it: a `go` typed next plans
        # from there, not from the filter's drifted pose, which may be off the new map.
        if not done.wait(PLACED_WITHIN_S):
            control.note(f"map save: the robot is not placed on the new map yet (no tick in "
                         f"{PLACED_WITHIN_S:g} s)")  # fmt: skip
        self.tell(PlanChanged(made.plan.path))
        self.tell(RouteShown.of(navigator.state))
        rooms = ", ".join(made.plan.rooms)
        wrote = tuple(f"wrote {path}" for path in made.written)
        return Reply(True, f"map saved: {made.plan.path}, {len(made.plan.rooms)} rooms "
                           f"({rooms}); `go ROOM` plans on it now",
                     lines=wrote + made.notes)  # fmt: skip

    def discard(self) -> Reply:
        with self._lock:
            run = self.run
            if run is None:
                return Reply(False, "map discard: not mapping")
            self._end(run)
        if self.navigator is not None:
            # The screens draw the plan again in place of the map they were shown.
            self.tell(PlanChanged(self.navigator.plan.path))
        return Reply(True, "mapping stopped; the map is thrown away")

    def close(self) -> None:
        with self._lock:
            if self.run is not None:
                self._end(self.run)

    def _end(self, run: MappingRun) -> None:
        with self._lock:
            if self.run is not run:
                return
            self.run = None
        if self.sensor is not None:
            self.sensor.unsubscribe(run.scan)
        self.control.unsubscribe(self._heard)
        run.close()

    def _heard(self, event: LoopEvent) -> None:
        run = self.run
        if run is not None and isinstance(event, Telemetry):
            sigma = event.estimate.sigma_heading if event.estimate is not None else 0.0
            run.pose(self.control.clock.now(), event.pose, sigma)

    def _laid_in(self, run: MappingRun) -> None:
        """On the run's thread, after a revolution: the screens' picture, now and then."""
        now = self.control.clock.now()
        revision = run.builder.revision
        if now - self._drawn_at < DRAWN_EVERY_S or revision == self._drawn_revision:
            return
        self._drawn_at, self._drawn_revision = now, revision
        self.tell(map_picture(run.grid(), revision))


def map_picture(grid: OccupancyGrid, revision: int) -> MapDrawn:
    """`grid` as a PNG no more than MAP_PICTURE_CELLS a side: a coarse cell is occupied
    if any of its cells is, else free if any is."""
    cells = grid.cells
    step = max(1, math.ceil(max(cells.shape) / MAP_PICTURE_CELLS))
    if step > 1:
        rows, cols = (math.ceil(n / step) * step for n in cells.shape)
        padded = np.full((rows, cols), 255, np.uint8)
        padded[: cells.shape[0], : cells.shape[1]] = cells
        blocks = padded.reshape(rows // step, step, cols // step, step)
        occupied = (blocks == OCCUPIED).any(axis=(1, 3))
        free = (blocks == FREE).any(axis=(1, 3))
        # The padding is added at the bottom and right: the origin (lower left) moves down.
        origin = (grid.origin[0], grid.origin[1] - (rows - cells.shape[0]) * grid.resolution)
    else:
        occupied, free, origin = cells == OCCUPIED, cells == FREE, grid.origin
    pixels = np.full(occupied.shape, _PIXEL_UNKNOWN, np.uint8)
    pixels[free] = _PIXEL_FREE
    pixels[occupied] = _PIXEL_OCCUPIED
    ok, png = cv2.imencode(".png", pixels)
    assert ok, "OpenCV encodes any 8-bit picture as PNG"
    return MapDrawn(png.tobytes(), grid.resolution * step, origin, revision)


def picture_grid(drawn: MapDrawn) -> OccupancyGrid | None:
    """The grid a MapDrawn's picture shows; None for one that is not such a picture (it
    crossed a socket: a PNG's header is read, and one larger than MAP_PICTURE_CELLS a
    side refused, before anything is decoded)."""
    png = drawn.png
    numbers = (drawn.resolution, *drawn.origin)
    if not (all(map(math.isfinite, numbers)) and drawn.resolution > 0):
        return None
    if len(png) < 24 or png[:8] != b"\x89PNG\r\n\x1a\n" or png[12:16] != b"IHDR":
        return None
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    if not (0 < width <= MAP_PICTURE_CELLS and 0 < height <= MAP_PICTURE_CELLS):
        return None
    pixels = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
    if pixels is None or pixels.ndim != 2:
        return None
    return OccupancyGrid.from_image(pixels, drawn.resolution, drawn.origin)
