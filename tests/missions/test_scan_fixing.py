"""The range sensor's revolutions fitted to the plan's map (missions/scan_fixing.py): a
fix where the robot really is, from a filter pose decimetres off; none more often than
the robot moves; none while there is no map to fit; and a corridor's fix says nothing
along it."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, replace

import numpy as np

from giraff_console.missions.pose_trail import REVOLUTION_S
from giraff_console.missions.scan_fixing import (
    ALONG_SIGMA_M,
    FIX_EVERY_M,
    FIX_SIGMA_M,
    ScanFixer,
)
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.robot.localisation import PoseFix
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import Walls, furnished_room, long_corridor, sweeps

RESOLUTION = 0.05
HALF = REVOLUTION_S / 2  # a revolution's middle, before its stamp


@dataclass(frozen=True)
class Revolution:
    range_max: float
    beams: tuple[tuple[float, float], ...]
    taken_at: float
    whole: bool = True


def grid_of(walls: Walls) -> OccupancyGrid:
    """The walls drawn into 5 cm cells, as a plan's grid has them."""
    left, bottom = walls[:, [0, 2]].min() - 1.0, walls[:, [1, 3]].min() - 1.0
    cols = math.ceil((walls[:, [0, 2]].max() + 1.0 - left) / RESOLUTION)
    rows = math.ceil((walls[:, [1, 3]].max() + 1.0 - bottom) / RESOLUTION)
    cells = np.full((rows, cols), FREE, dtype=np.uint8)
    for x0, y0, x1, y1 in walls:
        t = np.linspace(0.0, 1.0, max(2, math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.01)))
        col = np.floor((x0 + t * (x1 - x0) - left) / RESOLUTION).astype(int)
        row = rows - 1 - np.floor((y0 + t * (y1 - y0) - bottom) / RESOLUTION).astype(int)
        cells[row, col] = OCCUPIED
    return OccupancyGrid(cells, RESOLUTION, (left, bottom))


def revolution(walls: Walls, true: Pose, taken_at: float, seed: int) -> Revolution:
    (sweep,) = sweeps(walls, [true], 360, seed)
    return Revolution(sweep.range_max, sweep.beams, taken_at)


def believed(fixer: ScanFixer, pose: Pose, until: float) -> None:
    """The filter's pose, the same for the second before `until`, ticked at 20 Hz."""
    for k in range(20, -1, -1):
        fixer.pose(until - k * 0.05, pose, math.radians(1.0))


def fixer_of(grid: OccupancyGrid | None) -> tuple[ScanFixer, list[PoseFix]]:
    heard: list[PoseFix] = []
    return ScanFixer(lambda: grid, heard.append), heard


def test_a_scan_fixes_the_pose_where_the_robot_really_is() -> None:
    walls = furnished_room()
    fixer, _ = fixer_of(grid_of(walls))
    try:
        true = Pose(4.0, 2.5, math.radians(30))
        off = Pose(true.x + 0.15, true.y - 0.1, true.heading + math.radians(2.5))
        believed(fixer, off, 10.0)
        fix = fixer.fit(revolution(walls, true, 10.0, 1), 10.0 - HALF)
        assert fix is not None and fix.time == 10.0 - HALF and fix.pinned
        # Within a step of the matcher's fine lattice each way, as the mapping's match.
        assert math.dist((fix.pose.x, fix.pose.y), (true.x, true.y)) < 0.036
        assert abs(math.degrees(fix.pose.heading - true.heading)) <= 0.5
        assert np.allclose(np.diag(fix.covariance)[:2], FIX_SIGMA_M**2)
    finally:
        fixer.close()


def test_a_scan_fixes_again_only_once_the_robot_has_moved() -> None:
    walls = furnished_room()
    fixer, _ = fixer_of(grid_of(walls))
    try:
        true = Pose(4.0, 2.5, 0.0)
        believed(fixer, true, 10.0)
        assert fixer.fit(revolution(walls, true, 10.0, 1), 10.0 - HALF) is not None
        # Standing still: the same walls again would only repeat their errors.
        believed(fixer, true, 10.2)
        assert fixer.fit(revolution(walls, true, 10.2, 2), 10.2 - HALF) is None
        moved = Pose(true.x + FIX_EVERY_M + 0.01, true.y, 0.0)
        believed(fixer, moved, 10.5)
        assert fixer.fit(revolution(walls, moved, 10.5, 3), 10.5 - HALF) is not None
        assert fixer.fixes == 2
    finally:
        fixer.close()


def test_no_fix_without_a_map_or_while_turning() -> None:
    walls = furnished_room()
    fixer, _ = fixer_of(None)  # mapping: the plan is not drawn yet
    try:
        true = Pose(4.0, 2.5, 0.0)
        believed(fixer, true, 10.0)
        assert fixer.fit(revolution(walls, true, 10.0, 1), 10.0 - HALF) is None
    finally:
        fixer.close()
    fixer, _ = fixer_of(grid_of(walls))
    try:
        # Turning on the spot at 45 degrees a second: the revolution is smeared.
        for k in range(21):
            fixer.pose(9.0 + k * 0.05, Pose(4.0, 2.5, math.radians(45) * k * 0.05), 0.01)
        turned = Pose(4.0, 2.5, math.radians(45))
        assert fixer.fit(revolution(walls, turned, 10.0, 1), 10.0 - HALF) is None
    finally:
        fixer.close()


def test_no_fix_from_a_revolution_with_samples_lost() -> None:
    # A piece of a turn, or two run together (lidar/scan.py's whole_turn): the same
    # beams that fix the pose when whole give no fix.
    walls = furnished_room()
    true = Pose(4.0, 2.5, 0.0)
    whole = revolution(walls, true, 10.0, 1)
    for scan, fixes in ((replace(whole, whole=False), False), (whole, True)):
        fixer, _ = fixer_of(grid_of(walls))
        try:
            believed(fixer, true, 10.0)
            assert (fixer.fit(scan, 10.0 - HALF) is not None) is fixes
        finally:
            fixer.close()


def test_a_corridors_fix_says_nothing_along_it() -> None:
    walls = long_corridor()
    fixer, _ = fixer_of(grid_of(walls))
    try:
        true = Pose(15.0, 1.0, 0.0)
        believed(fixer, Pose(15.3, 0.9, math.radians(2.0)), 10.0)
        fix = fixer.fit(revolution(walls, true, 10.0, 1), 10.0 - HALF)
        assert fix is not None
        assert abs(fix.pose.y - true.y) < 0.036  # across: fixed
        assert abs(math.degrees(fix.pose.heading)) <= 0.5
        assert abs(fix.pose.x - 15.3) < 0.001  # along: the filter's, as it was
        assert fix.covariance[0, 0] >= 0.9 * ALONG_SIGMA_M**2
        assert fix.covariance[1, 1] < 2 * FIX_SIGMA_M**2
        assert not fix.pinned  # it refreshes nothing it did not measure
    finally:
        fixer.close()


def test_the_fixers_thread_hands_each_fix_on() -> None:
    walls = furnished_room()
    heard: list[PoseFix] = []
    came = threading.Event()

    def fitted(fix: PoseFix) -> None:
        heard.append(fix)
        came.set()

    fixer = ScanFixer(lambda: grid_of(walls), fitted)
    try:
        true = Pose(4.0, 2.5, 0.0)
        believed(fixer, true, 10.0)
        fixer.scan(revolution(walls, true, 10.0, 1))
        assert came.wait(5.0)
        assert len(heard) == 1 and heard[0].time == 10.0 - HALF
    finally:
        fixer.close()
    assert not any(thread.name == "scan fixes" for thread in threading.enumerate())


def test_a_fix_is_timed_by_the_sensors_own_turn() -> None:
    # A sensor turning 5 times a second: its revolutions' middles are 0.1 s before them.
    walls = furnished_room()
    heard: list[PoseFix] = []
    came = threading.Semaphore(0)

    def fitted(fix: PoseFix) -> None:
        heard.append(fix)
        came.release()

    fixer = ScanFixer(lambda: grid_of(walls), fitted)

    def at(t: float) -> Pose:  # driving along x at 0.6 m/s
        return Pose(3.0 + 0.6 * (t - 9.0), 2.5, 0.0)

    try:
        for k in range(41):
            fixer.pose(9.0 + k * 0.05, at(9.0 + k * 0.05), math.radians(1.0))
        for count, stamp in enumerate((10.6, 10.8), start=1):
            fixer.scan(revolution(walls, at(stamp - 0.1), stamp, count))
            assert came.acquire(timeout=5.0)
        assert abs(heard[1].time - 10.7) < 1e-9
        assert abs(heard[1].pose.x - at(10.7).x) < 0.036
    finally:
        fixer.close()
