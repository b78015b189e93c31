"""A master control's client of every vehicle on the broker (issue 28, item 3): what each
one says of itself, and go, pause, resume, cancel and dock sent to it as VDA 5050 orders
and instant actions.

Nothing in the robot depends on it: any master control that speaks VDA 5050 2.1 can
take its place. The fleet view (tui/fleet/) is one front end on it, the end-to-end tests
another; it holds no Textual.

What arrives is read on paho's thread (fleet/broker_link.py): parsed, checked against
the standard's schema, and kept per vehicle under a lock. A message that is not JSON or
fails the schema changes nothing but the vehicle's `problem` line. Readers take an
immutable snapshot (`fleet()`), are told of changes (`watch`), or wait for one
(`wait_until`).
"""

from __future__ import annotations

import enum
import json
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from typing import Any

from giraff_console.fleet.broker_link import Broker, BrokerLink
from giraff_console.fleet.messages import Headers, encode
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import Topic, VehicleId, every_vehicle, parse_topic
from giraff_console.fleet.vehicle_report import (
    Factsheet,
    VehicleState,
    connection_of,
    factsheet_of,
    state_of,
)
from giraff_console.fleet.vocabulary import ActionType, ConnectionState

# The most vehicles kept: a care home runs a handful, a site a few hundred. Beyond it a
# new one is counted and not kept, so that a flood of made-up serial numbers cannot grow
# the memory without end.
MAX_VEHICLES = 1000
# What the master listens to of every vehicle (§6.1); visualization is left out, as it
# only repeats the state's position at a higher rate.
HEARD = (Topic.STATE, Topic.CONNECTION, Topic.FACTSHEET)


@dataclass(frozen=True)
class Problem:
    """A message from a vehicle that could not be used: not JSON, or not valid by the
    standard's schema. Kept until a good message of the same kind arrives."""

    kind: Topic
    detail: str

    def __str__(self) -> str:
        return f"bad {self.kind.value}: {self.detail}"


@dataclass(frozen=True)
class Vehicle:
    """One vehicle as the master last heard it."""

    id: VehicleId
    connection: ConnectionState | None = None  # None until its `connection` is heard
    state: VehicleState | None = None
    factsheet: Factsheet | None = None
    heard_at: float = 0.0  # the master's clock, when anything last came from it
    problem: Problem | None = None

    @property
    def name(self) -> str:
        return self.id.name

    @property
    def reachable(self) -> bool:
        """Whether an order sent now could reach it: not OFFLINE nor CONNECTIONBROKEN.
        Unknown counts as reachable: a vehicle whose `connection` was never retained
        (another master's broker) may still be listening."""
        return self.connection not in (ConnectionState.OFFLINE, ConnectionState.CONNECTIONBROKEN)


@dataclass(frozen=True)
class Fleet:
    """Every vehicle heard, by name, and whether the master's own link is up. `version`
    rises with each change, so a reader can tell whether anything changed."""

    vehicles: tuple[Vehicle, ...] = ()
    link_up: bool = False
    version: int = 0
    ignored: int = 0  # vehicles beyond MAX_VEHICLES, not kept

    def get(self, vehicle: VehicleId) -> Vehicle | None:
        return next((v for v in self.vehicles if v.id == vehicle), None)


class Refusal(enum.Enum):
    """Why a command was not sent."""

    LINK_DOWN = "the master is not connected to the broker"
    UNKNOWN_VEHICLE = "no such vehicle on the broker"
    UNREACHABLE = "the vehicle is offline or its connection is broken"
    NO_STATE = "the vehicle has not said where it is (no state yet)"
    ALREADY_THERE = "the vehicle is in that room already"
    NOT_SENT = "the broker link did not take the message"


@dataclass(frozen=True)
class Sent:
    """A command on its way: the order's or the instant action's id, and where to."""

    vehicle: VehicleId
    kind: Topic
    id: str  # orderId, or the actionId of the one instant action
    what: str  # "go kitchen", "pause", ...

    def __str__(self) -> str:
        return f"{self.vehicle.name}: {self.what} sent ({self.id})"


@dataclass(frozen=True)
class Refused:
    vehicle: VehicleId
    what: str
    why: Refusal

    def __str__(self) -> str:
        return f"{self.vehicle.name}: {self.what} not sent: {self.why.value}"


def new_id(what: str) -> str:
    """An id no other order or action of any master has: the standard asks orderIds to
    be unique (§6.6.1), and a restarted master must not reuse its last ones. 32 random
    bits: short enough for the view's mission column, and a clash between two orders of
    the same robot is one in four billion."""
    return f"{what}-{uuid.uuid4().hex[:8]}"


class FleetMaster:
    """Every vehicle under `interface` on the broker, and commands to each.

    `start()` connects in the background; `stop()` hangs up. The methods are safe from
    any thread. `watch(callback)` calls `callback()` on paho's thread after each change:
    it must be quick (the view posts a message).
    """

    def __init__(self, broker: Broker, *, interface: str = "uagv", client_id: str | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 wall_clock: Callable[[], datetime] = lambda: datetime.now(UTC),
                 max_vehicles: int = MAX_VEHICLES) -> None:  # fmt: skip
        self.broker = broker
        self.interface = interface
        self.max_vehicles = max_vehicles
        self._clock = clock
        self._wall_clock = wall_clock
        self._changed = threading.Condition()
        self._vehicles: dict[VehicleId, Vehicle] = {}
        self._fleet = Fleet()
        self._watchers: list[Callable[[], None]] = []
        # headerId counts per topic, i.e. per vehicle and kind (§6.2).
        self._headers: dict[VehicleId, Headers] = {}
        self._send_lock = threading.Lock()
        self.link = BrokerLink(
            broker,
            client_id or new_id("giraff-fleet")[:23],  # MQTT 3.1.1 servers may ask <= 23
            heard=self.heard,
            connected=self.connected,
            subscriptions=tuple(every_vehicle(kind, interface) for kind in HEARD),
        )

    def start(self) -> None:
        self.link.start()

    def wait_up(self, timeout: float) -> bool:
        return self.link.wait_up(timeout)

    def stop(self) -> None:
        self.link.stop()

    def __enter__(self) -> FleetMaster:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # What is known.

    def fleet(self) -> Fleet:
        """The latest snapshot: immutable, so it may be read on any thread."""
        with self._changed:
            return self._fleet

    def watch(self, callback: Callable[[], None]) -> None:
        """Call `callback()` after every change, on the thread that made it."""
        with self._changed:
            self._watchers.append(callback)

    def wait_until(self, holds: Callable[[Fleet], bool], timeout: float) -> Fleet | None:
        """The first snapshot for which `holds(fleet)` is true, waiting up to `timeout`
        seconds of real time for it; None if it never held."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while not holds(self._fleet):
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self._changed.wait(left)
            return self._fleet

    # What arrives (paho's thread; public so that tests can hand messages in directly).

    def connected(self, up: bool) -> None:
        self._update(lambda fleet: replace(fleet, link_up=up))

    def heard(self, topic: str, payload: bytes) -> None:
        """One message from the broker: kept if it is a vehicle's, never raising."""
        parsed = parse_topic(topic)
        if parsed is None or parsed[0].interface != self.interface or parsed[1] not in HEARD:
            return
        vehicle, kind = parsed
        try:
            change = self._reading(kind, payload, vehicle)
        except _Unusable as error:
            found = Problem(kind, str(error))
            self._keep(vehicle, lambda v: replace(v, problem=found))
            return
        self._keep(vehicle, lambda v: _without_problem(change(v), kind))

    @staticmethod
    def _reading(kind: Topic, payload: bytes, vehicle: VehicleId) -> Callable[[Vehicle], Vehicle]:
        """What a message does to the vehicle; _Unusable if it is not JSON, fails the
        schema or is another vehicle's."""
        try:
            message = json.loads(payload)
        except (ValueError, RecursionError) as error:  # UnicodeDecodeError is a ValueError
            raise _Unusable(f"not JSON: {error}") from None
        wrong = problem(kind, message)
        if wrong is not None:
            raise _Unusable(wrong)
        if (message["manufacturer"], message["serialNumber"]) != (
            vehicle.manufacturer, vehicle.serial_number,
        ):  # fmt: skip
            raise _Unusable("its manufacturer and serialNumber are not the topic's")
        try:
            if kind is Topic.STATE:
                state = state_of(message)
                return lambda v: replace(v, state=state)
            if kind is Topic.CONNECTION:
                connection = connection_of(message)
                return lambda v: replace(v, connection=connection)
            factsheet = factsheet_of(message)
            return lambda v: replace(v, factsheet=factsheet)
        except (KeyError, ValueError, TypeError) as error:
            # The schema holds, yet a field is not what the reader takes (a schema looser
            # than the reader): a problem all the same, never a crash of paho's thread.
            raise _Unusable(f"{type(error).__name__}: {error}") from None

    def _keep(self, vehicle: VehicleId, change: Callable[[Vehicle], Vehicle]) -> None:
        now = self._clock()

        def changed(fleet: Fleet) -> Fleet:
            known = self._vehicles.get(vehicle)
            if known is None and len(self._vehicles) >= self.max_vehicles:
                return replace(fleet, ignored=fleet.ignored + 1)
            self._vehicles[vehicle] = replace(change(known or Vehicle(vehicle)), heard_at=now)
            vehicles = tuple(sorted(self._vehicles.values(), key=lambda v: v.name))
            return replace(fleet, vehicles=vehicles)

        self._update(changed)

    def _update(self, change: Callable[[Fleet], Fleet]) -> None:
        with self._changed:
            fleet = change(self._fleet)
            self._fleet = replace(fleet, version=self._fleet.version + 1)
            self._changed.notify_all()
            watchers = list(self._watchers)
        for watcher in watchers:
            watcher()

    # What is sent.

    def go(self, vehicle: VehicleId, room: str) -> Sent | Refused:
        """An order from the room the vehicle is in (its lastNodeId) to `room`: two
        nodes and the edge between them, all released, so that it starts at once."""
        what = f"go {room}"
        known = self.fleet().get(vehicle)
        refusal = self._refusal(known)
        if refusal is not None:
            return Refused(vehicle, what, refusal)
        assert known is not None
        if known.state is None:
            return Refused(vehicle, what, Refusal.NO_STATE)
        start = known.state.last_node_id
        if start == room:
            return Refused(vehicle, what, Refusal.ALREADY_THERE)
        order_id = new_id("go")
        order = {
            **self._header(vehicle, Topic.ORDER),
            "orderId": order_id,
            "orderUpdateId": 0,
            # The robot's nodes are rooms (its plan's ids): it plans its own way between
            # them, so an edge says only from which room to which.
            "nodes": [
                {"nodeId": start, "sequenceId": 0, "released": True, "actions": []},
                {"nodeId": room, "sequenceId": 2, "released": True, "actions": []},
            ],
            "edges": [
                {"edgeId": f"{start}--{room}", "sequenceId": 1, "released": True,
                 "startNodeId": start, "endNodeId": room, "actions": []},
            ],
        }  # fmt: skip
        return self._send(vehicle, Topic.ORDER, order, Sent(vehicle, Topic.ORDER, order_id, what))

    def pause(self, vehicle: VehicleId) -> Sent | Refused:
        return self.instant(vehicle, ActionType.START_PAUSE, "pause")

    def resume(self, vehicle: VehicleId) -> Sent | Refused:
        return self.instant(vehicle, ActionType.STOP_PAUSE, "resume")

    def cancel(self, vehicle: VehicleId) -> Sent | Refused:
        return self.instant(vehicle, ActionType.CANCEL_ORDER, "cancel")

    def dock(self, vehicle: VehicleId, dock: str) -> Sent | Refused:
        """To the dock: an order that ends in the plan's start room (`dock`), which the
        robot drives onto and charges on. An order, not startCharging, so that a fleet
        manager's traffic control sees the way (fleet/instant_actions.py)."""
        return self.go(vehicle, dock)

    def instant(self, vehicle: VehicleId, action: ActionType, what: str) -> Sent | Refused:
        """One instant action (`what` the operator asked, for the log). HARD: the vehicle
        does nothing else meanwhile, as pausing and cancelling are about its driving."""
        refusal = self._refusal(self.fleet().get(vehicle))
        if refusal is not None:
            return Refused(vehicle, what, refusal)
        action_id = new_id(action.value)
        message = {
            **self._header(vehicle, Topic.INSTANT_ACTIONS),
            "actions": [
                {"actionId": action_id, "actionType": action.value, "blockingType": "HARD"},
            ],
        }
        sent = Sent(vehicle, Topic.INSTANT_ACTIONS, action_id, what)
        return self._send(vehicle, Topic.INSTANT_ACTIONS, message, sent)

    def _refusal(self, known: Vehicle | None) -> Refusal | None:
        if not self.link.up:
            return Refusal.LINK_DOWN
        if known is None:
            return Refusal.UNKNOWN_VEHICLE
        if not known.reachable:
            return Refusal.UNREACHABLE
        return None

    def _header(self, vehicle: VehicleId, kind: Topic) -> dict[str, Any]:
        with self._send_lock:
            headers = self._headers.setdefault(vehicle, Headers(vehicle, self._wall_clock))
            return headers.stamp(kind, {})

    def _send(self, vehicle: VehicleId, kind: Topic, message: dict[str, Any],
              sent: Sent) -> Sent | Refused:  # fmt: skip
        # QoS 0, as the standard has it for order and instantActions (§6.1): a vehicle
        # that missed one says so in its state, and the operator sends it again.
        if not self.link.publish(vehicle.topic(kind), encode(message)):
            return Refused(vehicle, sent.what, Refusal.NOT_SENT)
        return sent


class _Unusable(ValueError):
    """A message that cannot be used, and why."""


def _without_problem(vehicle: Vehicle, kind: Topic) -> Vehicle:
    """A good message of `kind` clears a problem with the last one of that kind."""
    if vehicle.problem is not None and vehicle.problem.kind is kind:
        return replace(vehicle, problem=None)
    return vehicle
