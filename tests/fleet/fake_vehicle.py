"""A stand-in VDA 5050 vehicle for the master's and the fleet view's tests: it says what
a robot would (`connection` ONLINE, retained, with CONNECTIONBROKEN as its last will;
schema-valid `state`), keeps every order and instant action it is sent, and acts them
out at once: an order takes it straight to its last node, a pause pauses it, startCharging
takes it to the dock. The real vehicle (fleet/vehicle.py) is tested on its own.

`python -m tests.fleet.fake_vehicle URL SERIAL ROOM` runs one until it is killed, for a
test that kills it with SIGKILL.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import paho.mqtt.client as mqtt

from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import VERSION, Topic, VehicleId

CARE_HOME = "Example care home, ground floor"


def stamp() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


@dataclass
class Received:
    topic: str
    message: dict[str, Any]


@dataclass
class FakeVehicle:
    url: str
    serial: str
    room: str = "dock"
    map_id: str = CARE_HOME
    at: tuple[float, float, float] = (1.0, 2.0, 0.0)
    battery: float = 80.0
    errors: list[dict[str, Any]] = field(default_factory=list)
    received: list[Received] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.id = VehicleId("giraff", self.serial)
        self.order_id = ""
        self.nodes_left: list[dict[str, Any]] = []
        self.paused = False
        self.charging = False
        self._headers: dict[Topic, int] = {}
        self._heard = threading.Condition()
        host, port = self.url.removeprefix("mqtt://").split(":")
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"fake-{self.serial}",
                             protocol=mqtt.MQTTv311)  # fmt: skip
        client.will_set(self.id.topic(Topic.CONNECTION),
                        self._encode(Topic.CONNECTION, {"connectionState": "CONNECTIONBROKEN"}),
                        qos=1, retain=True)  # fmt: skip
        client.on_message = self._on_message
        self._up = threading.Event()
        client.on_connect = lambda *args: self._up.set()
        self.client = client
        self._host, self._port = host, int(port)

    def start(self, timeout: float = 5.0) -> FakeVehicle:
        self.client.connect(self._host, self._port, keepalive=5)
        self.client.loop_start()
        assert self._up.wait(timeout), "the fake vehicle did not connect"
        # Said only once the broker has the subscriptions (SUBACK): a master that orders
        # a vehicle as soon as it is seen must not find nobody listening (amqtt takes a
        # while, Mosquitto hardly any).
        subscribed = threading.Event()
        self.client.on_subscribe = lambda *args: subscribed.set()
        self.client.subscribe(
            [(self.id.topic(Topic.ORDER), 0), (self.id.topic(Topic.INSTANT_ACTIONS), 0)]
        )
        assert subscribed.wait(timeout), "the fake vehicle's subscriptions were not taken"
        self.say(Topic.CONNECTION, {"connectionState": "ONLINE"}, retain=True)
        self.publish_state()
        return self

    def stop(self) -> None:
        """A goodbye, as a vehicle that shuts down: OFFLINE, then hang up (once)."""
        if not self.client.is_connected():
            return
        self.say(Topic.CONNECTION, {"connectionState": "OFFLINE"}, retain=True)
        self.client.disconnect()
        self.client.loop_stop()

    def _encode(self, kind: Topic, body: dict[str, Any]) -> bytes:
        header = self._headers[kind] = self._headers.get(kind, -1) + 1
        message = {"headerId": header, "timestamp": stamp(), "version": VERSION,
                   "manufacturer": "giraff", "serialNumber": self.serial, **body}  # fmt: skip
        wrong = problem(kind, message)
        assert wrong is None, f"the fake vehicle's own {kind.value} is invalid: {wrong}"
        return json.dumps(message).encode()

    def say(self, kind: Topic, body: dict[str, Any], retain: bool = False) -> None:
        qos = 1 if kind is Topic.CONNECTION else 0
        info = self.client.publish(self.id.topic(kind), self._encode(kind, body), qos=qos,
                                   retain=retain)  # fmt: skip
        if qos:  # never from paho's own thread: the fake's connection is said from a test's
            info.wait_for_publish(5.0)

    def state(self) -> dict[str, Any]:
        x, y, theta = self.at
        position = {"x": x, "y": y, "theta": theta, "mapId": self.map_id,
                    "positionInitialized": True}  # fmt: skip
        return {
            "orderId": self.order_id,
            "orderUpdateId": 0,
            "lastNodeId": self.room,
            "lastNodeSequenceId": 0,
            "nodeStates": self.nodes_left,
            "edgeStates": [],
            "driving": False,
            "paused": self.paused,
            "operatingMode": "AUTOMATIC",
            "agvPosition": position,
            "batteryState": {"batteryCharge": self.battery, "charging": self.charging},
            "errors": self.errors,
            "actionStates": [],
            "safetyState": {"eStop": "NONE", "fieldViolation": False},
        }

    def publish_state(self) -> None:
        self.say(Topic.STATE, self.state())

    def wait_for(self, count: int, timeout: float = 5.0) -> list[Received]:
        """The first `count` messages it was sent, waiting up to `timeout` s for them."""
        with self._heard:
            self._heard.wait_for(lambda: len(self.received) >= count, timeout)
            assert len(self.received) >= count, f"{self.serial} was sent {self.received}"
            return list(self.received)

    def _on_message(self, client: mqtt.Client, userdata: object, msg: mqtt.MQTTMessage) -> None:
        if msg.topic not in (self.id.topic(Topic.ORDER), self.id.topic(Topic.INSTANT_ACTIONS)):
            return  # a broker's mistake (amqtt hands over others' retained messages)
        message = json.loads(msg.payload)
        with self._heard:
            self.received.append(Received(msg.topic, message))
            self._heard.notify_all()
        if msg.topic == self.id.topic(Topic.ORDER):
            # Straight there: the order's last node, the room it names.
            self.order_id = message["orderId"]
            self.room = message["nodes"][-1]["nodeId"]
            self.nodes_left = []
            self.charging = self.room == "dock"  # onto the dock, as a Giraff does
        else:
            for action in message["actions"]:
                kind = action["actionType"]
                if kind in ("startPause", "stopPause"):
                    self.paused = kind == "startPause"
                elif kind == "cancelOrder":
                    self.nodes_left = []
        self.publish_state()


if __name__ == "__main__":
    url, serial, room = sys.argv[1:4]
    vehicle = FakeVehicle(url, serial, room).start()
    print("up", flush=True)
    while True:  # until killed: state at 1 Hz, as a robot's
        time.sleep(1.0)
        vehicle.publish_state()
