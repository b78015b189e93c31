"""The lookout reads a lidar's revolution from where the robot was when it was taken:
the walls it saw stay walls however the robot has turned since, turning on the spot
as it was taken or after."""

from __future__ import annotations

import math

import numpy as np

from giraff_console.lidar.scan import LidarScan
from giraff_console.missions.lookout import Lookout
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.pose_trail import REVOLUTION_S
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.odometry import Pose
from tests.missions.site import PLAN


def walls_seen_from(navigator: Navigator, pose: Pose, taken_at: float) -> LidarScan:
    """A revolution from `pose` whose every hit is on a cell the plan's grid blocks
    within 0.6 to 1.5 m of it."""
    grid = navigator.walls
    assert grid is not None
    rows, cols = np.nonzero(grid.blocked(unknown_blocks=False))
    beams = []
    for row, col in zip(rows, cols, strict=True):
        x, y = grid.centre_of(int(row), int(col))
        distance = math.hypot(x - pose.x, y - pose.y)
        if 0.6 <= distance <= 1.5:
            beams.append((distance, math.remainder(math.atan2(y - pose.y, x - pose.x)
                                                   - pose.heading, math.tau)))  # fmt: skip
    assert len(beams) > 20
    return LidarScan(12.0, tuple(sorted(beams, key=lambda beam: beam[1])), taken_at, len(beams))


def start() -> tuple[Navigator, Pose]:
    navigator = Navigator(PLAN, walls_of(PLAN))
    x, y = PLAN.rooms["corridor"].at
    return navigator, Pose(x, y, 0.0)


def test_a_revolution_is_seen_from_where_it_was_taken() -> None:
    navigator, here = start()
    scan = walls_seen_from(navigator, here, taken_at=10.0)
    lookout = Lookout(navigator, lambda: scan)
    for k in range(5):  # still until the revolution ends
        lookout.sweep(here, 9.8 + 0.05 * k)
    # Read a tick later, the robot has since turned 20 degrees on the spot: seen from
    # there, the walls would be beside the walls, in the room.
    lookout.sweep(Pose(here.x, here.y, math.radians(20.0)), 10.05)
    assert navigator.state.obstacles == ()


def test_a_revolution_taken_turning_on_the_spot_is_seen_from_its_middle() -> None:
    navigator, here = start()

    def turned(t: float) -> Pose:  # turning on the spot at 45 degrees a second
        return Pose(here.x, here.y, math.radians(45.0) * (t - 9.8))

    # The walls as seen from where the robot was half way through the revolution.
    scan = walls_seen_from(navigator, turned(10.0 - REVOLUTION_S / 2), taken_at=10.0)
    lookout = Lookout(navigator, lambda: scan)
    for k in range(9):  # read until 10.2 s, the robot 13 degrees further round
        lookout.sweep(turned(9.8 + 0.05 * k), 9.8 + 0.05 * k)
    assert navigator.state.obstacles == ()
