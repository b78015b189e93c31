"""The instant actions a Giraff takes from the fleet (issue 28): to the dock and charging
and off it again, where it stands said by the fleet, a state and a factsheet on request;
any other action is FAILED with an error, and nothing moves for it. On a later board,
whose charger says when it charges (wire-facts: `charger_data`)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from giraff_console.fleet.topics import Topic
from giraff_console.planning.floorplan import load_floorplan
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import FleetRobot, Watcher, fleet_robots
from tests.fleet.test_vehicle import assert_every_message_valid

pytestmark = pytest.mark.timeout(150)

NEAR = "w-15"
# The simulator's clock: sixteen times real time, as the daemon's tests run theirs. No
# test here acts on the robot while it drives (each action is sent with it standing),
# and the robot is stepped on that clock, so the drives are the same, only shorter.
SIM_SPEED = 16.0


@pytest.fixture
def later(broker: Broker, wing: Path, tmp_path: Path) -> Iterator[tuple[FleetRobot, Watcher]]:
    watcher = Watcher(broker)
    try:
        with fleet_robots(
            broker, wing, tmp_path, 1, firmware="later", sim_speed=SIM_SPEED
        ) as robots:
            watcher.wait(lambda: watcher.latest(robots[0].id, Topic.STATE) is not None)
            yield robots[0], watcher
            assert_every_message_valid(watcher)
    finally:
        watcher.close()


def status(watcher: Watcher, robot: FleetRobot, action_id: str) -> str | None:
    for action in watcher.latest(robot.id, Topic.STATE)["actionStates"]:
        if action["actionId"] == action_id:
            return action["actionStatus"]
    return None


def result(watcher: Watcher, robot: FleetRobot, action_id: str) -> str:
    for action in watcher.latest(robot.id, Topic.STATE)["actionStates"]:
        if action["actionId"] == action_id:
            return action.get("resultDescription", "")
    return ""


def ended(watcher: Watcher, robot: FleetRobot, action_id: str, timeout: float = 60.0) -> str:
    watcher.wait(
        lambda: status(watcher, robot, action_id) in ("FINISHED", "FAILED"),
        timeout,
        f"the end of {action_id}",
    )
    result = status(watcher, robot, action_id)
    assert result is not None
    return result


def test_an_order_to_the_dock_charges_and_stop_charging_backs_off_it(later, wing):
    robot, watcher = later
    plan = load_floorplan(wing)
    watcher.order(robot.id, "o1", ["dock", NEAR])
    watcher.wait(lambda: watcher.latest(robot.id, Topic.STATE)["lastNodeId"] == NEAR, 60)
    # Away from the dock, startCharging drives nowhere: it says what to send instead.
    watcher.instant(robot.id, "startCharging", "too-soon")
    assert ended(watcher, robot, "too-soon", 10) == "FAILED"
    assert "an order that ends at dock" in result(watcher, robot, "too-soon")
    watcher.order(robot.id, "o2", [NEAR, "dock"])
    watcher.wait(
        lambda: (
            (said := watcher.latest(robot.id, Topic.STATE))["orderId"] == "o2"
            and not said["nodeStates"]
            and said["batteryState"]["charging"]
        ),
        60,
        "the order done, charging on the dock",
    )
    true = robot.robot.true_pose()
    assert math.dist((true.x, true.y), plan.rooms["dock"].at) < 0.1
    watcher.instant(robot.id, "startCharging", "charge")
    assert ended(watcher, robot, "charge", 10) == "FINISHED"
    watcher.instant(robot.id, "stopCharging", "uncharge")
    assert ended(watcher, robot, "uncharge") == "FINISHED"
    watcher.wait(
        lambda: not watcher.latest(robot.id, Topic.STATE)["batteryState"]["charging"],
        10,
        "not charging",
    )
    true = robot.robot.true_pose()
    assert 0.2 < math.dist((true.x, true.y), plan.rooms["dock"].at) < 0.5
    assert robot.robot.service.controls().holder is None  # let go, standing still


def test_init_position_says_where_the_robot_stands(later, wing):
    robot, watcher = later
    before = robot.robot.true_pose()
    watcher.instant(robot.id, "initPosition", "here",
                    {"x": 0.0, "y": 0.0, "theta": 0.0, "mapId": "Two wings round a hub",
                     "lastNodeId": NEAR})  # fmt: skip
    assert ended(watcher, robot, "here", 10) == "FINISHED"
    watcher.wait(lambda: watcher.latest(robot.id, Topic.STATE)["lastNodeId"] == NEAR, 10)
    watcher.instant(
        robot.id,
        "initPosition",
        "nowhere",
        {"x": 999.0, "y": 999.0, "theta": 0.0, "mapId": "Two wings round a hub"},
    )
    assert ended(watcher, robot, "nowhere", 10) == "FAILED"
    after = robot.robot.true_pose()
    assert (after.x, after.y) == (before.x, before.y)  # said, not driven
    assert robot.robot.service.controls().holder is None  # the fleet kept nothing


def test_state_and_factsheet_on_request_and_unknown_actions_fail(later):
    robot, watcher = later
    factsheets = sum(1 for h in watcher.heard if h.kind is Topic.FACTSHEET)
    watcher.instant(robot.id, "factsheetRequest", "sheet")
    assert ended(watcher, robot, "sheet", 10) == "FINISHED"
    watcher.wait(
        lambda: sum(1 for h in watcher.heard if h.kind is Topic.FACTSHEET) > factsheets,
        10,
        "a factsheet again",
    )
    watcher.instant(robot.id, "stateRequest", "state")
    assert ended(watcher, robot, "state", 10) == "FINISHED"
    watcher.instant(robot.id, "liftFork", "fork")
    assert ended(watcher, robot, "fork", 10) == "FAILED"
    errors = watcher.latest(robot.id, Topic.STATE)["errors"]
    assert any(
        e["errorType"] == "actionError" and "liftFork" in e["errorDescription"] for e in errors
    )
