"""The scan matcher: it finds the pose a scan fits, and says when a scan cannot say."""

from __future__ import annotations

import math

import numpy as np

from giraff_console.planning.map_building import MapBuilder
from giraff_console.planning.scan_matching import (
    FINE_STEP_M,
    MatchOutcome,
    likelihood_field,
    match,
    pinning,
)
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import ROOM_DRIVE, drive, furnished_room, sweeps


def test_a_scan_off_by_a_drift_is_matched_back_onto_the_room() -> None:
    walls = furnished_room()
    truth = drive(ROOM_DRIVE, 5.5)[:40]
    scans = sweeps(walls, truth, 360, 5)
    builder = MapBuilder(match_scans=False)
    for k, (pose, scan) in enumerate(zip(truth[:-1], scans[:-1], strict=True)):
        builder.add(pose, scan, k)
    builder.match_scans = True
    true = truth[-1]
    off = Pose(true.x + 0.2, true.y - 0.15, true.heading + math.radians(3))
    found = builder.add(off, scans[-1], 100)
    assert found.outcome is MatchOutcome.MATCHED and found.matched
    # Within a step of the fine lattice each way: the score is read from 5 cm cells, so
    # poses within a cell score alike. Over twelve sweep seeds of this drive the match
    # lands 0.025 or 0.035 m from the truth (five of them 0.035, before the map's walls
    # were kept from grazing beams as well as after).
    assert (
        math.dist((found.pose.x, found.pose.y), (true.x, true.y))
        <= math.hypot(FINE_STEP_M, FINE_STEP_M) + 1e-9
    )
    assert abs(math.degrees(found.pose.heading - true.heading)) <= 0.5
    assert found.shift_m >= 0.2 and found.quality >= 0.5


def test_a_scan_of_one_short_wall_is_not_matched() -> None:
    # 60 hits along 0.6 m of wall half a metre ahead: nothing else to fit.
    ys = np.linspace(-0.3, 0.3, 60)
    points = np.column_stack([np.full_like(ys, 0.5), ys])
    occupied = np.zeros((40, 40), dtype=bool)
    occupied[14:26, 30] = True
    field = likelihood_field(occupied, -1.0, 1.0, 0.05)
    found = match(field, Pose(), points, math.radians(1))
    assert found.outcome is MatchOutcome.FEATURELESS
    assert found.pose == Pose()


def test_a_corridor_pins_across_it_and_not_along_it() -> None:
    xs = np.arange(-6, 6, 0.03)
    points = np.concatenate([np.column_stack([xs, np.full_like(xs, 1.0)]),
                             np.column_stack([xs, np.full_like(xs, -1.0)])])  # fmt: skip
    order = np.argsort(np.arctan2(points[:, 1], points[:, 0]))
    pins = pinning(points[order], math.radians(1))
    assert abs(pins.weak[0]) > 0.99  # along the corridor, the robot's x
    assert pins.least < 0.2 and pins.most > 20
