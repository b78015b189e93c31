"""The operator always wins over the fleet (issue 28), even while the fleet's broker
floods the robot with messages: a console that takes the controls ends the fleet's
order at once and the fleet never touches the operator's own mission; an operator's
stop holds the fleet until an operator's `release`; the fleet keeps no controls while
the robot stands; and the room the robot stands in is said wherever it was driven."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from giraff_console.fleet.topics import Topic
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.mission import Outcome
from giraff_console.service import commands as c
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import VEHICLES_SAY, FleetRobot, Watcher, fleet_robots
from tests.fleet.order_flood import flooding
from tests.service.daemon_rig import wait_until

pytestmark = pytest.mark.timeout(150)

NURSE = "console of nurse Ada"
NEAR, NEXT = "w-15", "w-14"
# Seconds for the flood's process to start and fill the vehicle's inbox.
FLOOD_S = 15.0
# Seconds the broker may go on delivering what it held once the flood has ended.
WAKE_S = 15.0


# The simulator's clock for the test that drives whole legs and refuses an order only
# while a 4 m go is under way: eight times real time leaves that go about 5 s of wall
# time (at 16x, 3 s), the refusal's round trip over the broker a fraction of one. The
# others keep fleet_robots's four: a flood must start while the robot still drives.
LEGS_SPEED = 8.0


@contextmanager
def watched_robot(
    broker: Broker, wing: Path, tmp_path: Path, sim_speed: float
) -> Iterator[tuple[FleetRobot, Watcher]]:
    # As a master control hears them: what the vehicles say, not the orders sent them
    # (the flood's, which a watcher in the robot's process would spend its time on).
    watcher = Watcher(broker, kinds=VEHICLES_SAY)
    try:
        with fleet_robots(broker, wing, tmp_path, 1, sim_speed=sim_speed) as robots:
            watcher.wait(lambda: watcher.latest(robots[0].id, Topic.STATE) is not None)
            yield robots[0], watcher
    finally:
        watcher.close()


@pytest.fixture
def one(broker: Broker, wing: Path, tmp_path: Path) -> Iterator[tuple[FleetRobot, Watcher]]:
    with watched_robot(broker, wing, tmp_path, 4.0) as it:
        yield it


@pytest.fixture
def one_on_legs(broker: Broker, wing: Path, tmp_path: Path) -> Iterator[tuple[FleetRobot, Watcher]]:
    """`one`, on a clock LEGS_SPEED times real time."""
    with watched_robot(broker, wing, tmp_path, LEGS_SPEED) as it:
        yield it


def state(watcher: Watcher, robot: FleetRobot) -> dict:
    return watcher.latest(robot.id, Topic.STATE)


def test_a_take_ends_the_fleet_s_order_at_once_even_in_a_flood(one, broker, wing, tmp_path):
    robot, watcher = one
    service = robot.robot.service
    service.attach(NURSE, take=False)
    ends: list[MissionChanged] = []
    service.subscribe(
        lambda e: ends.append(e) if isinstance(e, MissionChanged) and not e.running else None
    )
    watcher.order(robot.id, "o1", ["dock", NEXT])
    watcher.wait(lambda: state(watcher, robot)["driving"], what="driving")
    log = tmp_path / "flood.log"
    with flooding(broker.port, robot.id, log) as flood:
        deadline = time.monotonic() + FLOOD_S
        while robot.vehicle.dropped == 0:
            assert flood.poll() is None, f"the flood ended: see {log}"
            assert time.monotonic() < deadline, f"no flood: see {log}"
            time.sleep(0.05)
        time.sleep(2.0)  # the vehicle's inbox kept full a while
        taken = time.monotonic()
        assert service.execute(c.TakeControls(), NURSE).ok
        deadline = time.monotonic() + 2.0
        while not ends:
            assert time.monotonic() < deadline, "the fleet's mission went on after the take"
            time.sleep(0.01)
        assert ends[0].end is not None and ends[0].end.outcome is Outcome.STOPPED_BY_OPERATOR
        assert time.monotonic() - taken < 0.5
        assert service.execute(c.Go(NEAR), NURSE).ok
    # The nurse's own mission: the fleet's cancel never touches it. Sent once the flood's
    # wake has passed (the broker delivers what it holds for a few seconds after the
    # flood's end, and the vehicle drops what does not fit its inbox: a cancel sent then
    # is never read), and waited for until the vehicle has answered it.
    calm = time.monotonic() + WAKE_S
    dropped, since = robot.vehicle.dropped, time.monotonic()
    while time.monotonic() - since < 1.0:
        assert time.monotonic() < calm, "the flood's wake went on"
        time.sleep(0.05)
        if robot.vehicle.dropped != dropped:
            dropped, since = robot.vehicle.dropped, time.monotonic()
    watcher.instant(robot.id, "cancelOrder", "cx")
    watcher.wait(lambda: action(watcher, robot, "cx") == "FAILED", 10, "the cancel refused")
    assert service.started_by() == NURSE and robot.robot.control.mission is not None
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeId"] == NEAR and not state(watcher, robot)["driving"]
        ),
        60,
        "the nurse's go done",
    )
    assert math.dist(_xy(robot), load_floorplan(wing).rooms[NEAR].at) <= 0.1
    wait_until(lambda: len(ends) == 2, 10, "the nurse's go's end")
    assert ends[1].end is not None and ends[1].end.outcome is Outcome.ARRIVED, ends


def action(watcher: Watcher, robot: FleetRobot, action_id: str) -> str | None:
    """The status the vehicle last said of its action `action_id`, if it said any."""
    said = {a["actionId"]: a["actionStatus"] for a in state(watcher, robot)["actionStates"]}
    return said.get(action_id)


def test_an_operator_s_stop_holds_the_fleet_until_release(one):
    robot, watcher = one
    service = robot.robot.service
    service.attach(NURSE, take=False)
    watcher.order(robot.id, "o1", ["dock", NEXT])
    watcher.wait(lambda: state(watcher, robot)["driving"], what="driving")
    assert service.execute(c.Halt(), NURSE).ok
    watcher.wait(lambda: not state(watcher, robot)["driving"], what="stopped")
    assert service.controls().holder is None  # a watching console's stop takes nothing
    stood = _xy(robot)
    here = state(watcher, robot)["lastNodeId"]
    watcher.order(robot.id, "o2", [here, NEXT])
    watcher.wait(
        lambda: any(
            "an operator stopped the robot" in e["errorDescription"]
            for e in state(watcher, robot)["errors"]
        ),
        what="the refusal",
    )
    time.sleep(1.0)
    assert math.dist(_xy(robot), stood) < 0.005
    assert service.execute(c.Release(), NURSE).ok
    watcher.order(robot.id, "o3", [here, NEXT])
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeId"] == NEXT and not state(watcher, robot)["nodeStates"]
        ),
        60,
        f"{NEXT} reached",
    )


def test_the_fleet_keeps_no_controls_while_the_robot_stands(one):
    robot, watcher = one
    service = robot.robot.service
    watcher.instant(robot.id, "stopPause", "nothing-to-resume")
    watcher.instant(robot.id, "initPosition", "placed", {"lastNodeId": "dock", "theta": 0.0})
    watcher.order(robot.id, "o-moon", ["dock", "the-moon"])
    watcher.wait(
        lambda: (
            {a["actionId"] for a in state(watcher, robot)["actionStates"]}
            >= {"nothing-to-resume", "placed"}
        ),
        what="the actions' ends",
    )
    watcher.wait(
        lambda: any(e["errorType"] == "orderError" for e in state(watcher, robot)["errors"]),
        what="the refusal",
    )
    assert service.controls().holder is None
    service.attach(NURSE)
    assert service.controls().holder == NURSE  # a console that comes takes them


def test_the_room_it_stands_in_is_said_wherever_it_was_driven_since(one_on_legs):
    robot, watcher = one_on_legs
    service = robot.robot.service
    watcher.order(robot.id, "o1", ["dock", NEAR])
    watcher.wait(
        lambda: (
            state(watcher, robot)["lastNodeId"] == NEAR and not state(watcher, robot)["nodeStates"]
        ),
        60,
        f"{NEAR} reached",
    )
    service.attach(NURSE)
    assert service.execute(c.Go(NEXT), NURSE).ok
    watcher.wait(lambda: state(watcher, robot)["driving"], 10, "the nurse's go")
    service.detach(NURSE)  # her mission carries on, and nobody holds the controls
    # The fleet does not take the robot from her mission.
    watcher.order(robot.id, "o-early", [state(watcher, robot)["lastNodeId"], NEAR])
    watcher.wait(
        lambda: any(
            "nurse Ada started is under way" in e["errorDescription"]
            for e in state(watcher, robot)["errors"]
        ),
        10,
        "the refusal",
    )
    deadline = time.monotonic() + 60
    while service.started_by() is not None:
        assert time.monotonic() < deadline, "the nurse's go did not end"
        time.sleep(0.1)
    watcher.wait(lambda: state(watcher, robot)["lastNodeId"] == NEXT, 10, f"{NEXT} said")
    watcher.order(robot.id, "o2", [NEXT, NEAR])  # as a master starts it: where it stands
    watcher.wait(
        lambda: (
            state(watcher, robot)["orderId"] == "o2"
            and state(watcher, robot)["lastNodeId"] == NEAR
            and not state(watcher, robot)["nodeStates"]
        ),
        60,
        f"back at {NEAR}",
    )


def _xy(robot: FleetRobot) -> tuple[float, float]:
    pose = robot.robot.true_pose()
    assert pose is not None
    return pose.x, pose.y
