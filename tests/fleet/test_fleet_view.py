"""The fleet view (tui/fleet/) on a real broker, with stand-in vehicles that publish as a
robot would and keep what the view sends them; and one snapshot, its messages handed
straight to the master so that nothing on it depends on timing or a port."""

from __future__ import annotations

import math
import signal
import subprocess
import sys
import time
from collections.abc import Callable

import pytest

from giraff_console.data_folders import example_floorplan
from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.master import FleetMaster
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import Topic
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.tui.fleet.app import FleetView
from giraff_console.tui.map_scene import plan_scene
from tests.fleet.fake_vehicle import CARE_HOME, FakeVehicle

pytestmark = pytest.mark.timeout(90)
WAIT_S = 5.0
SIZE = (120, 40)
PLAN = load_floorplan(example_floorplan())
WALLS = walls_of(PLAN)
assert WALLS is not None and PLAN.name == CARE_HOME


def fleet_view(master: FleetMaster) -> FleetView:
    return FleetView(master, plan=PLAN, scene=plan_scene(PLAN, WALLS),
                     timestamp=lambda: "12:00:00", cursor_blink=False)  # fmt: skip


def cell(app: FleetView, robot: str, column: str) -> str:
    return app.table.get_cell(robot, column).plain


def log_text(app: FleetView) -> str:
    """The log, its wrapped lines joined again (a line wraps after a space)."""
    return "".join(strip.text for strip in app.log_view.lines)


async def until(pilot, holds: Callable[[], bool], timeout: float = WAIT_S) -> float:
    """How long until `holds()`, letting the app run; fails after `timeout` s."""
    start = time.monotonic()
    while not holds():
        assert time.monotonic() - start < timeout, "never held"
        await pilot.pause(0.02)
    return time.monotonic() - start


async def test_ten_robots_are_listed_with_live_state(broker, master):
    fakes = [FakeVehicle(broker.url, f"giraff-{n:02}", room="dock").start() for n in range(10)]
    try:
        app = fleet_view(master)
        async with app.run_test(size=SIZE) as pilot:
            await until(pilot, lambda: app.table.row_count == 10)
            names = [fake.id.name for fake in fakes]
            await until(pilot, lambda: all(cell(app, n, "connection") == "ONLINE" for n in names))
            assert [str(row.value) for row in app.table.rows] == names
            fakes[3].battery = 15.0
            fakes[3].publish_state()
            await until(pilot, lambda: cell(app, names[3], "battery") == "15%")
    finally:
        for fake in fakes:
            fake.stop()


@pytest.mark.parametrize(
    ("key", "action_type"),
    [("p", "startPause"), ("r", "stopPause"), ("c", "cancelOrder")],
)
async def test_each_key_sends_its_instant_action_to_the_selected_robot(master, vehicle, key,
                                                                        action_type):  # fmt: skip
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        await pilot.press(key)
        await until(pilot, lambda: len(vehicle.received) == 1)
        (received,) = vehicle.received
        assert received.topic == "uagv/v2/giraff/giraff-01/instantActions"
        assert problem(Topic.INSTANT_ACTIONS, received.message) is None
        assert received.message["actions"][0]["actionType"] == action_type
        assert "giraff/giraff-01: " in log_text(app) and " sent (" in log_text(app)


async def test_go_asks_for_a_room_and_the_robot_reports_its_arrival(master, vehicle):
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        await pilot.press("g")
        await pilot.press(*"kitch", "enter")  # completed: the one room it begins
        await until(pilot, lambda: len(vehicle.received) == 1)
        order = vehicle.received[0].message
        assert vehicle.received[0].topic == "uagv/v2/giraff/giraff-01/order"
        assert problem(Topic.ORDER, order) is None
        assert [node["nodeId"] for node in order["nodes"]] == ["lobby", "kitchen"]
        await until(pilot, lambda: cell(app, "giraff/giraff-01", "mission")
                    == f"{order['orderId']} at kitchen ✓")  # fmt: skip


async def test_dock_sends_an_order_to_the_plan_s_start_room_where_the_robot_charges(
    master, vehicle
):
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        await pilot.press("d")
        await until(pilot, lambda: len(vehicle.received) == 1)
        order = vehicle.received[0].message
        assert vehicle.received[0].topic == "uagv/v2/giraff/giraff-01/order"
        assert problem(Topic.ORDER, order) is None
        assert [node["nodeId"] for node in order["nodes"]] == ["lobby", PLAN.start]


async def test_go_refuses_a_room_the_plan_does_not_have(master, vehicle):
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        await pilot.press("g", *"attic", "enter")
        assert "no room 'attic'" in str(app.screen.query_one("#refused").render())
        await pilot.press("escape")
        await pilot.pause(0.2)
        assert vehicle.received == []


async def test_a_malformed_state_is_shown_and_the_view_goes_on(master, vehicle):
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        vehicle.client.publish(vehicle.id.topic(Topic.STATE), b"{oops").wait_for_publish(WAIT_S)
        await until(pilot, lambda: "bad state: not JSON" in cell(app, "giraff/giraff-01", "error"))
        assert "giraff/giraff-01: bad state: not JSON" in log_text(app)
        vehicle.battery = 42.0
        vehicle.publish_state()
        await until(pilot, lambda: cell(app, "giraff/giraff-01", "battery") == "42%")
        assert cell(app, "giraff/giraff-01", "error") == ""


async def test_a_robots_error_is_shown_in_its_row_and_the_log(master, vehicle):
    app = fleet_view(master)
    async with app.run_test(size=SIZE) as pilot:
        await until(pilot, lambda: app.table.row_count == 1)
        vehicle.errors = [{"errorType": "noRouteError", "errorLevel": "WARNING",
                           "errorDescription": "no way to attic"}]  # fmt: skip
        vehicle.publish_state()
        said = "noRouteError: no way to attic (WARNING)"
        await until(pilot, lambda: cell(app, "giraff/giraff-01", "error") == said)
        assert f"giraff/giraff-01: {said}" in log_text(app)


async def test_a_killed_robot_shows_connection_broken_within_two_seconds(broker, master,
                                                                         tmp_path):  # fmt: skip
    process = subprocess.Popen(
        [sys.executable, "-m", "tests.fleet.fake_vehicle", broker.url, "giraff-09", "dock"],
        stdout=subprocess.PIPE, stderr=(tmp_path / "vehicle.log").open("wb"),
    )  # fmt: skip
    try:
        assert process.stdout is not None and process.stdout.readline() == b"up\n"
        app = fleet_view(master)
        async with app.run_test(size=SIZE) as pilot:
            name = "giraff/giraff-09"
            await until(pilot, lambda: app.table.row_count == 1
                        and cell(app, name, "connection") == "ONLINE")  # fmt: skip
            process.send_signal(signal.SIGKILL)
            process.wait(WAIT_S)
            took = await until(pilot, lambda: cell(app, name, "connection") == "CONNECTIONBROKEN",
                               timeout=2.0)  # fmt: skip
            assert took < 2.0
            assert "1 broken" in str(app.bar.render())
            assert f"{name}: CONNECTION BROKEN" in log_text(app)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(WAIT_S)


def test_the_fleet_view_at_120x40(snap_compare):
    """Four robots: one on the plan going to the day room, one whose connection broke,
    one on another map driven by hand with a fatal error, one that sent a bad state."""
    # Never started: the messages are handed in below, as paho's thread would.
    master = FleetMaster(BrokerAddress.parse("mqtt://127.0.0.1:1883"))
    nowhere = "mqtt://127.0.0.1:1"  # the stand-ins only write the messages
    kitchen = PLAN.rooms["kitchen"].at
    going = FakeVehicle(nowhere, "giraff-01", room="kitchen",
                        at=(kitchen[0], kitchen[1], math.pi / 2))  # fmt: skip
    going.order_id = "go-5eed0001"
    going.nodes_left = [{"nodeId": "day-room", "sequenceId": 2, "released": True}]
    broken = FakeVehicle(nowhere, "giraff-02", room="dock")
    elsewhere = FakeVehicle(nowhere, "giraff-03", room="ward-b", map_id="First floor",
                            battery=12.0)  # fmt: skip
    elsewhere.charging = True
    elsewhere.errors = [{"errorType": "localizationError", "errorLevel": "FATAL",
                         "errorDescription": "no marker seen"}]  # fmt: skip
    state = elsewhere.state() | {"operatingMode": "MANUAL"}

    def hand_in(fake: FakeVehicle, kind: Topic, body: dict) -> None:
        master.heard(fake.id.topic(kind), fake._encode(kind, body))

    master.connected(True)
    hand_in(going, Topic.CONNECTION, {"connectionState": "ONLINE"})
    hand_in(going, Topic.STATE, going.state())
    hand_in(broken, Topic.STATE, broken.state())
    hand_in(broken, Topic.CONNECTION, {"connectionState": "CONNECTIONBROKEN"})
    hand_in(elsewhere, Topic.CONNECTION, {"connectionState": "ONLINE"})
    hand_in(elsewhere, Topic.STATE, state)
    master.heard("uagv/v2/giraff/giraff-04/state", b'{"headerId": 1}')
    app = fleet_view(master)
    assert snap_compare(app, terminal_size=SIZE)
