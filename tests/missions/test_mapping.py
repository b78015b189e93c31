"""A mapping run's revolutions (missions/mapping.py): which are laid into the map."""

from __future__ import annotations

from giraff_console.lidar.scan import LidarScan
from giraff_console.missions.mapping import MappingRun
from giraff_console.planning.map_building import MapBuilder
from tests.mapping.buildings import WING_DRIVE, care_home_wing, drive, sweeps

RATE = 5.5


def test_a_revolution_with_samples_lost_is_left_out_and_counted() -> None:
    walls = care_home_wing()
    truth = drive(WING_DRIVE, RATE)[:60]
    run = MappingRun(MapBuilder(keep=True), lambda text: None, truth[0])
    run.close()  # laid in here, on this thread
    broken = set(range(5, len(truth), 7))
    for k, (pose, sweep) in enumerate(zip(truth, sweeps(walls, truth, 360, 1), strict=True)):
        run.pose(k / RATE, pose, 0.01)
        run.lay_in(LidarScan(sweep.range_max, tuple(sweep.beams), k / RATE, 360,
                             whole=k not in broken))  # fmt: skip
    status = run.status()
    assert status.broken == len(broken) > 0
    assert status.scans + status.turning + status.broken == len(truth)
    laid = {round(scan.stamp * RATE) for scan in run.builder.laid}
    assert laid and not laid & broken


def test_a_revolution_with_samples_lost_is_counted_as_it_comes_never_queued() -> None:
    # On the sensor's thread, at once: queued, it could push a whole one out of the
    # run's short queue (MAX_WAITING, the newest kept).
    walls = care_home_wing()
    (pose,) = drive(WING_DRIVE, RATE)[:1]
    (sweep,) = sweeps(walls, [pose], 360, 1)
    run = MappingRun(MapBuilder(), lambda text: None, pose)
    run.close()  # nothing queued is laid in from here on
    run.scan(LidarScan(sweep.range_max, tuple(sweep.beams), 0.0, 360, whole=False))
    assert run.status().broken == 1
