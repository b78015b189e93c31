"""What every driving mission is built with (missions/drive_setup.py): the same parts,
whichever mission, and a clear error where there is no floor plan to go by."""

from __future__ import annotations

import pytest

from giraff_console.missions.docking import DOCK, GoToPose, back_to
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.odometry import Pose
from tests.missions.site import LIMITS, PLAN, TICK


@pytest.fixture(scope="module")
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


@pytest.mark.parametrize(("build", "kind"), [
    (lambda drives: drives.go("kitchen"), GoTo),
    (lambda drives: drives.go(DOCK), GoToPose),
    (lambda drives: drives.arrive("the nurse station", back_to(Pose(10.0, 7.0, 0.0))), GoToPose),
])  # fmt: skip
def test_every_mission_is_built_with_the_setups_parts(navigator, build, kind):
    start = navigator.start_pose
    assert start is not None
    notes: list[str] = []
    drives = DriveSetup(navigator, lambda: start, TICK, limits=LIMITS, notify=notes.append)
    mission = build(drives)
    assert isinstance(mission, kind)
    assert mission.limits is LIMITS and mission.tick == TICK
    assert mission.notify == notes.append
    assert mission.pose_now() == start
    assert mission.navigator is navigator


def test_without_a_floor_plan_no_room_can_be_gone_to():
    drives = DriveSetup(None, lambda: Pose(), TICK)
    with pytest.raises(PlanningError, match="no floor plan"):
        drives.go("kitchen")
