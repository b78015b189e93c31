"""Robots on a broker for the fleet tests: each a runtime.Robot (the composition root's,
as `serve --sim` builds it) with its fleet link, in this process; and a watcher that
hears every message on the broker, as a fleet manager would."""

from __future__ import annotations

import itertools
import json
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt

from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.messages import Headers, encode
from giraff_console.fleet.topics import Topic, VehicleId, every_vehicle, parse_topic
from giraff_console.fleet.vehicle import FleetVehicle
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.settings import FleetSettings, Settings
from tests.fleet.broker import Broker

WAIT_S = 30.0
# What the vehicles send, as a master control subscribes to it.
VEHICLES_SAY = (Topic.STATE, Topic.VISUALIZATION, Topic.CONNECTION, Topic.FACTSHEET)


@dataclass
class FleetRobot:
    robot: Robot
    vehicle: FleetVehicle

    @property
    def id(self) -> VehicleId:
        return self.vehicle.vehicle


@contextmanager
def fleet_robots(
    broker: Broker,
    plan: Path,
    folder: Path,
    count: int,
    *,
    sim_speed: float = 4.0,
    landmarks: bool = True,
    fleet: FleetSettings | None = None,
    prefix: str = "g",
    firmware: str | None = None,
    first: int = 1,
    eye: tuple[float, str] | None = None,
    before_start: Callable[[FleetRobot], None] = lambda robot: None,
) -> Iterator[list[FleetRobot]]:
    """`count` simulated robots in `plan`'s building, each a vehicle on `broker`, serial
    numbers `prefix`01, `prefix`02, ... (from `first`: several processes on one broker,
    as bench/fleet.py runs them); `eye`: the simulated cameras' frames a second and size
    (as `--eye-fps` and `--eye-size` say; the defaults without it); `before_start` sees each
    before it starts; started and on the broker, and closed afterwards (OFFLINE said)."""
    settings = Settings(fleet=fleet or FleetSettings())
    address = BrokerAddress.parse(broker.url)
    with ExitStack() as stack:
        robots = []
        for number in range(first, first + count):
            options = RobotOptions(
                floorplan=plan,
                sim_speed=sim_speed,
                landmarks=landmarks,
                firmware=firmware,
                eye_fps=eye[0] if eye is not None else None,
                eye_size=eye[1] if eye is not None else None,
                recordings=folder / f"rec{number}",
                routes=folder / f"routes{number}",
            )
            robot = stack.enter_context(Robot(options, settings, plan))
            vehicle = FleetVehicle(
                robot.service, address, VehicleId("giraff", f"{prefix}{number:02d}"), settings
            )
            stack.callback(vehicle.close)
            robots.append(FleetRobot(robot, vehicle))
        for each in robots:
            before_start(each)
        for each in robots:
            each.robot.start()
            each.vehicle.start()
        # Each on the broker before a master comes: amqtt 0.12 hands a client that
        # connects every retained message matching anyone's subscription, so a vehicle
        # connecting after a master's wildcards (a busy machine) is handed the others'
        # connection and factsheet, which it rightly refuses (counted in `bad`).
        for each in robots:
            assert each.vehicle.link.wait_up(WAIT_S), f"{each.id.name} not on the broker"
        yield robots


@dataclass
class Heard:
    topic: str
    kind: Topic
    vehicle: VehicleId
    message: Any  # the decoded JSON
    retained: bool
    at: float = field(default_factory=time.monotonic)


class Watcher:
    """Everything every vehicle says on the broker, as a master control hears it; and a
    master's way to send orders and instant actions."""

    def __init__(
        self, broker: Broker, name: str = "watcher", kinds: tuple[Topic, ...] = tuple(Topic)
    ) -> None:
        """`kinds`: what it hears; all by default, orders and instant actions too."""
        self.heard: list[Heard] = []
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=name)
        self._client.on_message = self._on_message
        self._client.connect("127.0.0.1", broker.port)
        if set(kinds) == set(Topic):
            self._client.subscribe("uagv/v2/+/+/+", qos=1)
        else:
            self._client.subscribe([(every_vehicle(kind), 1) for kind in kinds])
        self._client.loop_start()
        self._headers: dict[VehicleId, Headers] = {}

    def close(self) -> None:
        self._client.disconnect()
        self._client.loop_stop()

    def _on_message(self, client: mqtt.Client, userdata: object, message: mqtt.MQTTMessage) -> None:
        parsed = parse_topic(message.topic)
        if parsed is None:
            return
        try:
            decoded = json.loads(message.payload)
        except ValueError:
            decoded = None
        with self._changed:
            self.heard.append(
                Heard(message.topic, parsed[1], parsed[0], decoded, bool(message.retain))
            )
            self._changed.notify_all()

    def latest(self, vehicle: VehicleId, kind: Topic) -> Any:
        with self._lock:
            for heard in reversed(self.heard):
                if heard.vehicle == vehicle and heard.kind is kind:
                    return heard.message
        return None

    def sent_by_vehicles(self) -> list[Heard]:
        """What the vehicles sent (not the orders and actions on the broker)."""
        with self._lock:
            return [h for h in self.heard if h.kind not in (Topic.ORDER, Topic.INSTANT_ACTIONS)]

    def wait(self, test: Callable[[], bool], timeout: float = WAIT_S, what: str = "") -> None:
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                self._lock.release()
                try:
                    if test():
                        return
                finally:
                    self._lock.acquire()
                left = deadline - time.monotonic()
                assert left > 0, f"no {what or 'such message'} within {timeout:g} s"
                self._changed.wait(min(left, 0.2))

    def publish(self, vehicle: VehicleId, kind: Topic, body: dict[str, Any]) -> dict[str, Any]:
        headers = self._headers.setdefault(vehicle, Headers(vehicle))
        message = headers.stamp(kind, body)
        self.send_raw(vehicle.topic(kind), encode(message))
        return message

    def send_raw(self, topic: str, payload: bytes) -> None:
        self._client.publish(topic, payload, qos=0).wait_for_publish(5.0)

    def order(
        self,
        vehicle: VehicleId,
        order_id: str,
        rooms: list[str],
        *,
        update: int = 0,
        released: int | None = None,
        first_sequence: int = 0,
    ) -> dict[str, Any]:
        released = len(rooms) if released is None else released
        nodes = [
            {
                "nodeId": room,
                "sequenceId": first_sequence + 2 * i,
                "released": i < released,
                "actions": [],
            }
            for i, room in enumerate(rooms)
        ]
        edges = [
            {
                "edgeId": f"{a}>{b}",
                "sequenceId": first_sequence + 2 * i + 1,
                "released": i + 1 < released,
                "startNodeId": a,
                "endNodeId": b,
                "actions": [],
            }
            for i, (a, b) in enumerate(itertools.pairwise(rooms))
        ]
        return self.publish(
            vehicle,
            Topic.ORDER,
            {"orderId": order_id, "orderUpdateId": update, "nodes": nodes, "edges": edges},
        )

    def instant(
        self,
        vehicle: VehicleId,
        action_type: str,
        action_id: str,
        parameters: dict[str, Any] | None = None,
    ) -> dict[str, Any]:
        action = instant_action(action_type, action_id, parameters)
        return self.publish(vehicle, Topic.INSTANT_ACTIONS, {"actions": [action]})


def instant_action(
    action_type: str, action_id: str, parameters: dict[str, Any] | None = None
) -> dict[str, Any]:
    """One action of an instantActions message, as a master control writes it."""
    action: dict[str, Any] = {
        "actionId": action_id,
        "actionType": action_type,
        "blockingType": "HARD",
    }
    if parameters:
        action["actionParameters"] = [{"key": k, "value": v} for k, v in parameters.items()]
    return action
