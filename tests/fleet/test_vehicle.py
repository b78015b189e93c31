"""A robot as a VDA 5050 vehicle (issue 28), on a real broker, built by the composition
root as `serve --sim --fleet` builds it: what it says, how orders become missions, and
what it refuses. Where the robot went is read from the simulator's true pose."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import Topic
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.service import commands as c
from giraff_console.service.robot_service import HERE
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import FleetRobot, Watcher, fleet_robots

pytestmark = pytest.mark.timeout(120)

NEAR = "w-15"  # 3 m from the dock
NEXT = "w-14"  # 4 m on along the west corridor
ARRIVAL_M = 0.10


# The simulator's clock for the tests that send an order and look only at where it ends,
# with the robot standing between what they send (the robot is stepped on that clock,
# so the drive is the same; only the wall time is shorter): sixteen times real time,
# as the daemon's tests run theirs. Those that act on the robot while it drives keep
# fleet_robots's four, which leaves the broker's round trip the time it had.
WHOLE_ORDERS_SPEED = 16.0


@contextmanager
def watched_robot(
    broker: Broker, wing: Path, tmp_path: Path, sim_speed: float
) -> Iterator[tuple[FleetRobot, Watcher]]:
    watcher = Watcher(broker)
    try:
        with fleet_robots(broker, wing, tmp_path, 1, sim_speed=sim_speed) as robots:
            watcher.wait(
                lambda: watcher.latest(robots[0].id, Topic.STATE) is not None, what="a first state"
            )
            yield robots[0], watcher
            assert_every_message_valid(watcher)
    finally:
        watcher.close()


@pytest.fixture
def one(broker: Broker, wing: Path, tmp_path: Path) -> Iterator[tuple[FleetRobot, Watcher]]:
    with watched_robot(broker, wing, tmp_path, 4.0) as it:
        yield it


@pytest.fixture
def one_fast(broker: Broker, wing: Path, tmp_path: Path) -> Iterator[tuple[FleetRobot, Watcher]]:
    """`one`, on a clock WHOLE_ORDERS_SPEED times real time."""
    with watched_robot(broker, wing, tmp_path, WHOLE_ORDERS_SPEED) as it:
        yield it


def assert_every_message_valid(watcher: Watcher) -> None:
    """Every message a vehicle sent, by the standard's own schemas."""
    wrong = [
        (heard.topic, problem(heard.kind, heard.message))
        for heard in watcher.sent_by_vehicles()
        if problem(heard.kind, heard.message) is not None
    ]
    assert wrong == []


def state(watcher: Watcher, robot: FleetRobot) -> dict:
    return watcher.latest(robot.id, Topic.STATE)


def errors(watcher: Watcher, robot: FleetRobot) -> list[str]:
    return [error["errorType"] for error in state(watcher, robot)["errors"]]


def at(robot: FleetRobot, room: str, wing: Path) -> float:
    true = robot.robot.true_pose()
    assert true is not None
    return math.dist((true.x, true.y), load_floorplan(wing).rooms[room].at)


def test_a_robot_says_who_and_where_it_is_from_the_start(one):
    robot, watcher = one
    watcher.wait(lambda: watcher.latest(robot.id, Topic.FACTSHEET) is not None, what="factsheet")
    connection = watcher.latest(robot.id, Topic.CONNECTION)
    assert connection["connectionState"] == "ONLINE"
    said = state(watcher, robot)
    assert said["lastNodeId"] == "dock"
    assert said["operatingMode"] == "AUTOMATIC"
    assert said["agvPosition"]["positionInitialized"]
    assert said["agvPosition"]["mapId"] == "Two wings round a hub"
    facts = watcher.latest(robot.id, Topic.FACTSHEET)
    assert facts["typeSpecification"]["agvKinematic"] == "DIFF"
    assert facts["physicalParameters"]["speedMax"] <= 0.4


def test_an_order_runs_room_by_room_and_its_nodes_leave_the_state(one_fast, wing):
    robot, watcher = one_fast
    plan = load_floorplan(wing)
    watcher.order(robot.id, "o1", ["dock", NEAR, NEXT])
    watcher.wait(lambda: state(watcher, robot)["orderId"] == "o1", what="the order taken")
    watcher.wait(lambda: state(watcher, robot)["lastNodeId"] == NEAR, what=f"{NEAR} reached")
    assert [n["nodeId"] for n in state(watcher, robot)["nodeStates"]] == [NEXT]
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeId"] == NEXT and not state(watcher, robot)["nodeStates"]
        ),
        60,
        f"{NEXT} reached",
    )
    said = state(watcher, robot)
    assert said["lastNodeSequenceId"] == 4
    assert said["edgeStates"] == [] and said["errors"] == []
    assert at(robot, NEXT, wing) <= ARRIVAL_M
    position = said["agvPosition"]
    assert math.dist((position["x"], position["y"]), plan.rooms[NEXT].at) <= ARRIVAL_M


def test_an_order_for_a_room_the_plan_lacks_is_refused_and_nothing_moves(one, wing):
    robot, watcher = one
    watcher.order(robot.id, "o-moon", ["dock", "the-moon"])
    watcher.wait(lambda: "orderError" in errors(watcher, robot), what="the refusal")
    said = state(watcher, robot)
    assert said["orderId"] == "" and said["nodeStates"] == []
    assert at(robot, "dock", wing) < 0.01


def test_an_order_that_does_not_start_where_the_robot_is_is_refused(one):
    robot, watcher = one
    watcher.order(robot.id, "o-elsewhere", [NEAR, NEXT])
    watcher.wait(lambda: "orderError" in errors(watcher, robot), what="the refusal")
    assert "the robot is in dock" in state(watcher, robot)["errors"][0]["errorDescription"]


def test_an_order_through_a_shut_door_is_refused_whole(one, wing):
    robot, watcher = one
    plan = load_floorplan(wing)
    door = next(d for d in plan.doors if NEAR in d.between)
    service = robot.robot.service
    assert service.execute(c.Door(door.id, open=False)).ok
    service.let_go(HERE)  # shutting a door took the controls, as a key would
    watcher.order(robot.id, "o-shut", ["dock", NEXT, NEAR])
    watcher.wait(lambda: "noRouteError" in errors(watcher, robot), what="the refusal")
    assert at(robot, "dock", wing) < 0.01  # not even the first, open, leg was driven


def test_the_operator_holding_the_controls_wins_and_the_fleet_sees_why(one, wing):
    robot, watcher = one
    robot.robot.service.attach("console of nurse Ada")  # takes the controls
    watcher.wait(lambda: state(watcher, robot)["operatingMode"] == "MANUAL", what="MANUAL")
    watcher.order(robot.id, "o-held", ["dock", NEAR])
    watcher.wait(lambda: "operatorHasControls" in errors(watcher, robot), what="the refusal")
    assert "nurse Ada" in state(watcher, robot)["errors"][-1]["errorDescription"]
    assert at(robot, "dock", wing) < 0.01


def test_a_console_that_takes_the_controls_ends_the_order_under_way(one, wing):
    robot, watcher = one
    service = robot.robot.service
    service.attach("console of nurse Ada", take=False)
    watcher.order(robot.id, "o-taken", ["dock", NEXT])
    watcher.wait(lambda: state(watcher, robot)["driving"], what="driving")
    assert service.execute(c.TakeControls(), "console of nurse Ada").ok
    watcher.wait(lambda: "operatorHasControls" in errors(watcher, robot), what="the order ended")
    said = state(watcher, robot)
    assert said["nodeStates"] == [] and said["operatingMode"] == "MANUAL"
    watcher.wait(lambda: not state(watcher, robot)["driving"], what="standing still")


def test_cancel_stops_the_robot_and_clears_the_order(one, wing):
    robot, watcher = one
    watcher.instant(robot.id, "cancelOrder", "c0")
    watcher.wait(lambda: "noOrderToCancel" in errors(watcher, robot), what="nothing to cancel")
    watcher.order(robot.id, "o-cancel", ["dock", NEXT])
    watcher.wait(lambda: state(watcher, robot)["driving"], what="driving")
    watcher.instant(robot.id, "cancelOrder", "c1")

    def cancelled() -> bool:
        actions = {a["actionId"]: a["actionStatus"] for a in state(watcher, robot)["actionStates"]}
        return actions.get("c1") == "FINISHED"

    watcher.wait(cancelled, what="the cancel finished")
    watcher.wait(lambda: not state(watcher, robot)["driving"], what="standing still")
    assert state(watcher, robot)["nodeStates"] == []
    assert at(robot, NEXT, wing) > 1.0  # stopped on its way


def test_pause_holds_the_order_and_resume_finishes_it(one, wing):
    robot, watcher = one
    watcher.order(robot.id, "o-pause", ["dock", NEAR])
    watcher.wait(lambda: state(watcher, robot)["driving"], what="driving")
    watcher.instant(robot.id, "startPause", "p1")
    watcher.wait(lambda: state(watcher, robot)["paused"], what="paused")
    watcher.wait(lambda: not state(watcher, robot)["driving"], what="standing still")
    watcher.instant(robot.id, "stopPause", "p2")
    watcher.wait(lambda: state(watcher, robot)["lastNodeId"] == NEAR, 60, f"{NEAR} reached")
    assert at(robot, NEAR, wing) <= ARRIVAL_M


def test_the_horizon_waits_for_an_update_that_starts_at_the_last_released_node(one_fast, wing):
    robot, watcher = one_fast
    watcher.order(robot.id, "o-h", ["dock", NEAR, NEXT], released=2)
    watcher.wait(lambda: state(watcher, robot)["lastNodeId"] == NEAR, 60, f"{NEAR} reached")
    watcher.wait(lambda: not state(watcher, robot)["driving"], what="standing still")
    said = state(watcher, robot)
    assert [(n["nodeId"], n["released"]) for n in said["nodeStates"]] == [(NEXT, False)]
    # An update that does not start at the last released node is refused ...
    watcher.order(robot.id, "o-h", [NEXT, "w-13"], update=1, first_sequence=4)
    watcher.wait(lambda: "orderUpdateError" in errors(watcher, robot), what="the refusal")
    # ... one that does goes on.
    watcher.order(robot.id, "o-h", [NEAR, NEXT], update=2, first_sequence=2)
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeId"] == NEXT
            and state(watcher, robot)["orderUpdateId"] == 2
        ),
        60,
        f"{NEXT} reached",
    )
    assert at(robot, NEXT, wing) <= ARRIVAL_M


def test_an_order_back_to_the_dock_docks_and_finishes(one_fast, wing):
    robot, watcher = one_fast
    watcher.order(robot.id, "o-home", ["dock", NEAR, "dock"])
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeSequenceId"] == 4
            and not state(watcher, robot)["nodeStates"]
        ),
        90,
        "back on the dock",
    )
    assert state(watcher, robot)["lastNodeId"] == "dock" and errors(watcher, robot) == []
    assert at(robot, "dock", wing) <= ARRIVAL_M
