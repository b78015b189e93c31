"""The master control's client (fleet/master.py) on a real broker, with stand-in vehicles
(tests/fleet/fake_vehicle.py) that publish as a robot would and keep what they are sent."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from datetime import UTC, datetime

import pytest

from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.master import (
    Fleet,
    FleetMaster,
    Refusal,
    Refused,
    Sent,
)
from giraff_console.fleet.messages import timestamp
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import Topic, VehicleId
from giraff_console.fleet.vocabulary import ConnectionState, OperatingMode
from tests.fleet.fake_vehicle import FakeVehicle

pytestmark = pytest.mark.timeout(60)
WAIT_S = 5.0


def online(name: str):
    def holds(fleet: Fleet) -> bool:
        v = next((v for v in fleet.vehicles if v.name == name), None)
        return v is not None and v.connection is ConnectionState.ONLINE and v.state is not None

    return holds


def test_a_vehicle_is_listed_with_its_connection_and_state(master, vehicle):
    fleet = master.wait_until(online("giraff/giraff-01"), WAIT_S)
    assert fleet is not None
    seen = fleet.get(vehicle.id)
    assert seen is not None and seen.state is not None
    assert seen.state.last_node_id == "lobby"
    assert seen.state.mode is OperatingMode.AUTOMATIC
    assert seen.state.battery_charge == 80.0
    assert seen.state.position is not None and seen.state.position.x == 1.0
    assert seen.problem is None


def test_ten_vehicles_are_listed_and_ten_orders_reach_them(broker, master):
    fakes = [FakeVehicle(broker.url, f"giraff-{n:02}", room="dock").start() for n in range(10)]
    try:
        assert master.wait_until(lambda f: sum(v.state is not None for v in f.vehicles) == 10,
                                 WAIT_S)  # fmt: skip
        rooms = [f"room-{101 + n}" for n in range(10)]
        results = [master.go(fake.id, room) for fake, room in zip(fakes, rooms, strict=True)]
        assert all(isinstance(result, Sent) for result in results), results

        def arrived(fleet: Fleet) -> bool:
            where = {v.name: v.state for v in fleet.vehicles}
            return all(
                (state := where.get(fake.id.name)) is not None
                and state.last_node_id == room and state.arrived
                for fake, room in zip(fakes, rooms, strict=True)
            )  # fmt: skip

        assert master.wait_until(arrived, WAIT_S), master.fleet()
    finally:
        for fake in fakes:
            fake.stop()


def test_go_sends_a_schema_valid_order_from_where_the_vehicle_is(master, vehicle):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    first = master.go(vehicle.id, "kitchen")
    assert master.wait_until(lambda f: f.get(vehicle.id).state.last_node_id == "kitchen", WAIT_S)
    second = master.go(vehicle.id, "day-room")
    assert isinstance(first, Sent) and isinstance(second, Sent)
    received = vehicle.wait_for(2)
    orders = [r.message for r in received]
    assert {r.topic for r in received} == {"uagv/v2/giraff/giraff-01/order"}
    for order in orders:
        assert problem(Topic.ORDER, order) is None
    assert [o["headerId"] for o in orders] == [0, 1]
    assert orders[0]["orderId"] == first.id != orders[1]["orderId"] == second.id
    assert orders[0]["orderUpdateId"] == 0
    assert [n["nodeId"] for n in orders[0]["nodes"]] == ["lobby", "kitchen"]
    # The second starts where the first ended: the vehicle said so in its state.
    assert [n["nodeId"] for n in orders[1]["nodes"]] == ["kitchen", "day-room"]
    assert [n["sequenceId"] for n in orders[0]["nodes"]] == [0, 2]
    (edge,) = orders[0]["edges"]
    assert (edge["sequenceId"], edge["startNodeId"], edge["endNodeId"]) == (1, "lobby", "kitchen")
    assert orders[0]["timestamp"].endswith("Z")


@pytest.mark.parametrize(
    ("command", "action_type"),
    [("pause", "startPause"), ("resume", "stopPause"), ("cancel", "cancelOrder")],
)  # fmt: skip
def test_each_button_is_one_schema_valid_instant_action(master, vehicle, command, action_type):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    result = getattr(master, command)(vehicle.id)
    assert isinstance(result, Sent)
    (received,) = vehicle.wait_for(1)
    assert received.topic == "uagv/v2/giraff/giraff-01/instantActions"
    assert problem(Topic.INSTANT_ACTIONS, received.message) is None
    (action,) = received.message["actions"]
    assert action["actionType"] == action_type
    assert action["actionId"] == result.id


def test_a_vehicle_reports_the_pause_and_the_dock(master, vehicle):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    master.pause(vehicle.id)
    assert master.wait_until(lambda f: f.get(vehicle.id).state.paused, WAIT_S)
    assert isinstance(master.dock(vehicle.id, "dock"), Sent)
    docked = master.wait_until(lambda f: f.get(vehicle.id).state.charging, WAIT_S)
    assert docked is not None and docked.get(vehicle.id).state.last_node_id == "dock"


def test_commands_are_refused_rather_than_sent_where_they_cannot_work(broker, master, vehicle):
    stranger = VehicleId("giraff", "nobody")
    assert master.go(stranger, "kitchen") == Refused(stranger, "go kitchen",
                                                     Refusal.UNKNOWN_VEHICLE)  # fmt: skip
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    assert master.go(vehicle.id, "lobby").why is Refusal.ALREADY_THERE
    vehicle.stop()
    assert master.wait_until(
        lambda f: f.get(vehicle.id).connection is ConnectionState.OFFLINE, WAIT_S
    )
    assert master.pause(vehicle.id).why is Refusal.UNREACHABLE
    assert vehicle.received == []


@pytest.mark.parametrize(
    ("payload", "says"),
    [(b"{not json", "not JSON"), (b'{"headerId": 1}', "bad state"),
     (b"\xff\xfe", "not JSON")],
)  # fmt: skip
def test_a_malformed_or_invalid_state_is_kept_as_a_problem(master, vehicle, payload, says):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    before = master.fleet().get(vehicle.id)
    vehicle.client.publish(vehicle.id.topic(Topic.STATE), payload).wait_for_publish(WAIT_S)
    fleet = master.wait_until(lambda f: f.get(vehicle.id).problem is not None, WAIT_S)
    assert fleet is not None
    seen = fleet.get(vehicle.id)
    assert says in str(seen.problem)
    assert seen.state == before.state  # nothing taken from it
    # The next good state clears it; the master went on all along.
    vehicle.publish_state()
    assert master.wait_until(lambda f: f.get(vehicle.id).problem is None, WAIT_S)


def test_a_state_under_another_vehicles_topic_is_not_believed(master, vehicle):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    body = vehicle._encode(Topic.STATE, vehicle.state())
    vehicle.client.publish("uagv/v2/giraff/impostor/state", body).wait_for_publish(WAIT_S)
    fleet = master.wait_until(lambda f: len(f.vehicles) == 2, WAIT_S)
    assert fleet is not None
    impostor = fleet.get(VehicleId("giraff", "impostor"))
    assert impostor is not None and impostor.state is None
    assert "not the topic's" in str(impostor.problem)


def test_vehicles_beyond_the_limit_are_counted_not_kept(broker):
    address = BrokerAddress.parse(broker.url)
    master = FleetMaster(address, max_vehicles=3)  # not started: messages handed in
    for n in range(5):
        master.heard(f"uagv/v2/giraff/g{n}/state", b"{}")
    fleet = master.fleet()
    assert [v.name for v in fleet.vehicles] == ["giraff/g0", "giraff/g1", "giraff/g2"]
    assert fleet.ignored == 2


def test_other_interfaces_and_topics_are_ignored(broker):
    master = FleetMaster(BrokerAddress.parse(broker.url))
    master.heard("other/v2/giraff/g1/state", b"{}")
    master.heard("uagv/v1/giraff/g1/state", b"{}")
    master.heard("uagv/v2/giraff/g1/order", b"{}")
    assert master.fleet().vehicles == ()


def test_a_killed_vehicle_shows_connection_broken_within_two_seconds(broker, master, tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-m", "tests.fleet.fake_vehicle", broker.url, "giraff-09", "dock"],
        stdout=subprocess.PIPE, stderr=(tmp_path / "vehicle.log").open("wb"),
    )  # fmt: skip
    try:
        assert process.stdout is not None and process.stdout.readline() == b"up\n"
        killed = VehicleId("giraff", "giraff-09")
        assert master.wait_until(online(killed.name), WAIT_S)
        process.send_signal(signal.SIGKILL)
        process.wait(WAIT_S)
        start = time.monotonic()
        broken = master.wait_until(
            lambda f: f.get(killed).connection is ConnectionState.CONNECTIONBROKEN, 2.0
        )
        assert broken is not None, f"still {master.fleet().get(killed).connection}"
        assert time.monotonic() - start < 2.0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(WAIT_S)


def test_wait_until_gives_up_after_its_timeout(broker):
    master = FleetMaster(BrokerAddress.parse(broker.url))
    start = time.monotonic()
    assert master.wait_until(lambda f: len(f.vehicles) > 0, 0.2) is None
    assert 0.2 <= time.monotonic() - start < 1.0


def test_the_timestamp_is_iso8601_in_utc_with_a_z():
    assert timestamp(datetime(2025, 3, 1, 12, 0, 5, 120000, tzinfo=UTC)) == (
        "2025-03-01T12:00:05.120Z"
    )


def test_an_order_carries_the_standards_fields_and_no_others(master, vehicle):
    assert master.wait_until(online(vehicle.id.name), WAIT_S)
    master.go(vehicle.id, "kitchen")
    (received,) = vehicle.wait_for(1)
    assert set(received.message) == {
        "headerId", "timestamp", "version", "manufacturer", "serialNumber", "orderId",
        "orderUpdateId", "nodes", "edges",
    }  # fmt: skip
    assert json.dumps(received.message).count("giraff-01") == 1
