"""The navigator: `go <room>` from the robot's pose, and doors closed under the route."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.room_graph import NoRouteError, UnknownDoorError, UnknownRoomError
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.odometry import Pose

EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"


@pytest.fixture(scope="module")
def plan():
    return load_floorplan(EXAMPLE)


@pytest.fixture
def navigator(plan) -> Navigator:
    return Navigator(plan, walls_of(plan))


def test_the_robot_starts_at_the_start_rooms_point_facing_its_heading(navigator):
    assert navigator.start_pose == Pose(2.0, 7.0, math.radians(90))


def test_go_plans_from_the_pose_and_shows_the_route(navigator):
    planned = navigator.go("day-room", Pose(2.0, 7.5, 0.0))
    assert planned.path[0] == (2.0, 7.5) and planned.path[-1] == (36, 16)
    assert planned.route.doors == ["dock-corridor", "day-room-corridor"]
    assert navigator.state.goal == "day-room" and navigator.state.planned is planned


def test_closing_a_door_on_the_route_replans_round_it(navigator):
    navigator.go("day-room", Pose(2.0, 7.5, 0.0))
    state = navigator.close("day-room-corridor", Pose(20.0, 11.0, 0.0))
    assert "day-room-corridor" in state.closed
    assert state.planned is not None and state.planned.path[0] == (20.0, 11.0)
    assert "day-room-corridor" not in state.planned.route.doors
    assert state.planned.route.rooms[-1] == "day-room"
    state = navigator.open("day-room-corridor", Pose(20.0, 11.0, 0.0))
    assert state.planned is not None and state.planned.route.doors == ["day-room-corridor"]


def test_shutting_every_way_in_leaves_the_goal_with_the_reason(navigator):
    navigator.go("kitchen", Pose(2.0, 7.5, 0.0))
    navigator.close("kitchen-dining-room", Pose(2.0, 7.5, 0.0))
    state = navigator.close("kitchen-east-hall", Pose(2.0, 7.5, 0.0))
    assert state.goal == "kitchen" and state.planned is None
    assert "no route" in state.problem


def test_unknown_rooms_and_doors_are_planning_errors_that_change_nothing(navigator):
    with pytest.raises(UnknownRoomError, match="attic"):
        navigator.go("attic", Pose(2.0, 7.5, 0.0))
    with pytest.raises(UnknownDoorError, match="trapdoor"):
        navigator.close("trapdoor", Pose(2.0, 7.5, 0.0))
    assert navigator.state.goal is None and navigator.state.closed == frozenset()


def test_a_route_through_closed_doors_only_is_refused(plan):
    navigator = Navigator(plan, None)
    navigator.close("dock-corridor", Pose(2.0, 7.5, 0.0))
    with pytest.raises(NoRouteError):
        navigator.go("kitchen", Pose(2.0, 7.5, 0.0))
