"""A flood of long orders to one vehicle from a process of its own, as a fleet floods a
robot from another machine: `flooding(...)` runs `python -m tests.fleet.order_flood PORT
MANUFACTURER SERIAL`, which sends them to the broker on 127.0.0.1:PORT as fast as it
takes them until it is ended.

Not a thread in the test's process, beside the robot: there the sender and paho's thread
writing its 20 kB messages took the interpreter (the GIL) from the robot's control loop,
as no fleet on another machine can; with two busy loops beside it the loop's ticks took
up to 0.38 s (0.25 s from a process of its own), and a take's end of the fleet's order,
told at the loop's next tick, once came 0.59 s late (test_operator_wins.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import paho.mqtt.client as mqtt

from giraff_console.fleet.topics import Topic, VehicleId

NODES = 100
SEND_S = 5.0
END_S = 5.0
# The flood ends itself this long after it began, or as soon as its parent is gone: a
# test process killed outright leaves no flooder behind for a later test's broker.
LIFETIME_S = 120.0
ROOT = Path(__file__).resolve().parents[2]  # where `tests` is a package


@contextmanager
def flooding(port: int, vehicle: VehicleId, log: Path) -> Iterator[subprocess.Popen[bytes]]:
    """The flood on the broker at `port` while in the block (what it says in `log`);
    ended afterwards, whatever the block does."""
    with log.open("ab") as said:
        process = subprocess.Popen(
            [sys.executable, "-m", "tests.fleet.order_flood", str(port),
             vehicle.manufacturer, vehicle.serial_number],
            stdin=subprocess.DEVNULL, stdout=said, stderr=said, cwd=ROOT,
        )  # fmt: skip
    try:
        yield process
    finally:
        process.kill()
        process.wait(END_S)


def long_order(vehicle: VehicleId) -> bytes:
    """An order of NODES nodes on one spot: well formed, so the vehicle checks it all
    (the schema's check of a long order takes a while) before it refuses it, another
    order running."""
    nodes = [
        {"nodeId": "w-15", "sequenceId": 2 * i, "released": True, "actions": []}
        for i in range(NODES)
    ]
    edges = [
        {
            "edgeId": f"e{i}",
            "sequenceId": 2 * i + 1,
            "released": True,
            "startNodeId": "w-15",
            "endNodeId": "w-15",
            "actions": [],
        }
        for i in range(NODES - 1)
    ]
    return json.dumps(
        {
            "headerId": 1,
            "timestamp": "2026-11-28T00:00:00.00Z",
            "version": "2.1.0",
            "manufacturer": vehicle.manufacturer,
            "serialNumber": vehicle.serial_number,
            "orderId": "flood",
            "orderUpdateId": 0,
            "nodes": nodes,
            "edges": edges,
        }
    ).encode()


def flood(port: int, vehicle: VehicleId) -> None:
    parent, ends = os.getppid(), time.monotonic() + LIFETIME_S
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="order-flood")
    client.connect("127.0.0.1", port)
    client.loop_start()
    topic, payload = vehicle.topic(Topic.ORDER), long_order(vehicle)
    # Until ended (or orphaned, or LIFETIME_S on): each as soon as the broker took the last.
    while os.getppid() == parent and time.monotonic() < ends:
        try:
            client.publish(topic, payload, qos=0).wait_for_publish(SEND_S)
        except (RuntimeError, ValueError):
            # Not queued: amqtt hangs up on a sender that floods it, and paho's thread
            # connects again.
            time.sleep(0.05)


if __name__ == "__main__":
    port, manufacturer, serial = sys.argv[1:4]
    flood(int(port), VehicleId(manufacturer, serial))
