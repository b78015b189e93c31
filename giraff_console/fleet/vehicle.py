"""The robot as a VDA 5050 vehicle on an MQTT broker (issue 28): a client of the robot
service, as a console is, started by the daemon (`serve --fleet`, or the [fleet]
settings table).

One thread of its own does everything that touches the order (fleet/order_run.py) and
sends every message; paho's thread only hands over what arrives, into an inbox of
INBOX_SIZE messages: a flood fills it, and what does not fit is dropped and reported,
never queued without bound. The service's events are queued apart, so that a flood of
messages from the broker never crowds out a mission's end.

A message is checked before anything acts on it: its size (the link's), that it is
JSON, the standard's schema (fleet/schemas.py), the major version, and that it is for
this vehicle. Anything wrong is an error in `state` and a line in the journal; nothing
wrong in a message ever moves the robot.
"""

from __future__ import annotations

import collections
import json
import socket
import threading
import time
from typing import Any

from giraff_console.fleet.broker_link import Broker, BrokerLink
from giraff_console.fleet.factsheet import factsheet
from giraff_console.fleet.instant_actions import InstantActions
from giraff_console.fleet.messages import Headers, encode
from giraff_console.fleet.order_run import FLEET, OrderRun
from giraff_console.fleet.orders import MAX_ID, MAX_NODES, ErrorType, long_id
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.state_report import (
    Error,
    VehicleFacts,
    state_body,
    visualization_body,
)
from giraff_console.fleet.topics import MAJOR, Topic, VehicleId
from giraff_console.fleet.vocabulary import ConnectionState, ErrorLevel
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.service.events import Controls, GoReported, RoomRenamed, ServiceEvent
from giraff_console.service.robot_service import RobotService
from giraff_console.settings import Settings

# `state` at least this often (§6.10: "at least every 30 s"; fleet views want 1 Hz).
STATE_PERIOD_S = 1.0
# ... and on every change, at most this often: a robot flickering between two states
# must not flood the broker.
MIN_STATE_GAP_S = 0.1
# How often the thread looks for a change it was not told of (driving, the e-stop).
LOOK_S = 0.1
# Messages from the broker waiting to be read; more are dropped (a flood).
INBOX_SIZE = 64
# How long a flood is said in `state` after its last dropped message.
FLOOD_SAID_S = 10.0
# The service's events the fleet acts on; the rest (the board's exchanges, notes, 80 a
# second) are not queued at all.
HEEDED = (GoReported, MissionChanged, Controls, RoomRenamed)
# A line in the journal for dropped or bad messages at most this often.
NOTE_GAP_S = 5.0


def serial_number(settings: Settings) -> str:
    """The vehicle's serial number: the setting's, else the machine's host name."""
    return settings.fleet.serial_number or socket.gethostname().split(".")[0]


class FleetVehicle:
    """The fleet link of one robot; `start` it, `close` it (OFFLINE is said)."""

    def __init__(
        self, service: RobotService, broker: Broker, vehicle: VehicleId, settings: Settings
    ) -> None:
        self.service = service
        self.vehicle = vehicle
        self.settings = settings
        self.headers = Headers(vehicle)
        self.run = OrderRun(service, self._note, settings.motion.v_max)
        self.actions = InstantActions(self.run, self._publish_factsheet)
        self.link = BrokerLink(
            broker,
            f"{vehicle.manufacturer}.{vehicle.serial_number}",
            heard=self._heard_broker,
            connected=self._connected,
            subscriptions=(vehicle.topic(Topic.ORDER), vehicle.topic(Topic.INSTANT_ACTIONS)),
            # Stamped afresh at each connection: a master that orders a vehicle's messages
            # by headerId or time must not take the will for older than its ONLINE.
            will=(
                vehicle.topic(Topic.CONNECTION),
                lambda: self._connection_message(ConnectionState.CONNECTIONBROKEN),
            ),
        )
        self._inbox: collections.deque[tuple[str, bytes]] = collections.deque()
        # Only the few events the fleet acts on (missions' ends, the controls, a room's new
        # name): never dropped, and never crowded out by the inbox (see _turn).
        self._events: collections.deque[ServiceEvent] = collections.deque()
        self._wake = threading.Event()
        self._closing = threading.Event()
        self._connection: bool | None = None  # as the thread last acted on it
        self._up = False  # as paho last said
        self._ever_up = False
        self._refusal_noted: str | None = None
        self.dropped = 0  # messages dropped by a full inbox
        self._dropped_seen = (0, -FLOOD_SAID_S)  # the count, and when it last grew
        self.bad = 0  # messages that were not for us, not JSON, or not by the schema
        self._noted_at = -NOTE_GAP_S
        self._unnoted = 0
        self._last: tuple[object, ...] | None = None
        self._sent_at = -STATE_PERIOD_S
        self._thread = threading.Thread(target=self._loop, name="fleet", daemon=True)

    def start(self) -> None:
        # `yields`: a console that takes the controls ends the fleet's mission at once.
        self.service.attach(FLEET, take=False, yields=True)
        self.service.subscribe(self._heard_service)
        # An operator's stop holds the fleet until an operator's `release`, as it holds
        # the program on the virtual port: an automatic master would send the robot off
        # again seconds after someone stopped it.
        self.service.on_stop.append(self._operator_stopped)
        self.service.on_release.append(self._released)
        self.link.start()
        self._thread.start()
        self._note(
            f"fleet: {self.vehicle.name} joining the broker at "
            f"{self.link.broker.host}:{self.link.broker.port}"
        )

    def close(self, timeout: float = 3.0) -> None:
        """Say OFFLINE (§6.14: a vehicle that leaves on purpose), and leave."""
        self._closing.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout)
        self.service.unsubscribe(self._heard_service)
        self.service.on_stop.remove(self._operator_stopped)
        self.service.on_release.remove(self._released)
        self.service.detach(FLEET)
        self.link.stop(
            last=(
                self.vehicle.topic(Topic.CONNECTION),
                self._connection_message(ConnectionState.OFFLINE),
            )
        )

    # -- on other threads: only queue ---------------------------------------------------

    def _heard_broker(self, topic: str, payload: bytes) -> None:
        if len(self._inbox) >= INBOX_SIZE:
            self.dropped += 1
        else:
            self._inbox.append((topic, payload))
        self._wake.set()

    def _connected(self, up: bool) -> None:
        self._up = up
        self._wake.set()

    def _heard_service(self, event: ServiceEvent) -> None:
        if isinstance(event, HEEDED):
            self._events.append(event)
            self._wake.set()

    def _operator_stopped(self) -> None:
        self.run.hold("an operator stopped the robot")
        self._wake.set()

    def _released(self) -> None:
        self.run.hold(None)
        self._wake.set()

    # -- the vehicle's thread -----------------------------------------------------------

    def _loop(self) -> None:
        while not self._closing.is_set():
            # Woken when the next state is due, not up to LOOK_S after it (a state at
            # 0.93 Hz, measured, before).
            due = self._sent_at + STATE_PERIOD_S - time.monotonic()
            self._wake.wait(due if 0 < due < LOOK_S else LOOK_S)
            self._wake.clear()
            try:
                self._turn()
            except Exception as error:  # a bug here must not end the fleet link silently
                self._note(f"fleet: internal error, carrying on: {error!r}")

    def _turn(self) -> None:
        up = self._up
        refusal = self.link.refusal
        if refusal is not None and refusal != self._refusal_noted:
            self._note(
                f"fleet: the broker refuses this vehicle: {refusal} (the credentials "
                "file, or the broker's password file and ACL: docs/fleet-deployment.md)"
            )
        self._refusal_noted = refusal
        if up != self._connection:
            self._broker_changed(up)
        self._heed()
        # What waits now, and no more: a flood must not keep this turn from ending.
        for _ in range(len(self._inbox)):
            topic, payload = self._inbox.popleft()
            self._read(topic, payload)
            # What the service said meanwhile comes first (a console that took the
            # controls, a mission's end); and a state when one is due, however many
            # messages wait: reading a burst of long orders takes seconds (measured:
            # 3.7 s), which the fleet must not take for the robot gone.
            self._heed()
            self._send_state()
        if self.dropped or self._unnoted:
            self._note_trouble()
        self._send_state()

    def _heed(self) -> None:
        while self._events:
            event = self._events.popleft()
            self.run.heard(event)
            self.actions.heard(event)

    def _broker_changed(self, up: bool) -> None:
        was_up, self._connection = self._connection, up
        if up:
            self._publish(
                Topic.CONNECTION,
                {"connectionState": ConnectionState.ONLINE.value},
                retain=True,
                qos=1,
            )
            self._publish_factsheet()
            self._last = None  # a state at once
            if self._ever_up:
                self._note("fleet: the broker is back; state sent again")
            else:
                self._note("fleet: on the broker")
            self._ever_up = True
        elif was_up:
            stop = self.settings.fleet.stops_when_broker_lost
            self._note(
                "fleet: the broker went; "
                + ("the order is stopped" if stop else "the order carries on")
                + "; trying again"
            )
            self.run.broker_lost(stop)

    def _read(self, topic: str, payload: bytes) -> None:
        kinds = {self.vehicle.topic(kind): kind for kind in (Topic.ORDER, Topic.INSTANT_ACTIONS)}
        kind = kinds.get(topic)
        if kind is None:
            # Not what it subscribed to: a broker that got it wrong (amqtt 0.12 hands a
            # new subscriber others' retained messages) is never obeyed.
            self.bad += 1
            self._unnoted += 1
            return
        try:
            message = json.loads(payload)
        except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError
            self._bad(kind, "not JSON")
            return
        if not isinstance(message, dict):
            self._bad(kind, "not a JSON object")
            return
        nodes = message.get("nodes")
        if kind is Topic.ORDER and isinstance(nodes, list) and len(nodes) > MAX_NODES:
            # Before the schema, whose check of a long order takes a while.
            self._bad(kind, f"{len(nodes)} nodes; at most {MAX_NODES}", message.get("headerId"))
            return
        try:
            wrong = problem(kind, message)
        except RecursionError:
            wrong = "nested too deep"
        if wrong is not None:
            self._bad(kind, wrong, message.get("headerId"))
            return
        if str(message["version"]).split(".")[0] != MAJOR.removeprefix("v"):
            self._bad(
                kind,
                f"version {message['version']}; this vehicle speaks {MAJOR.removeprefix('v')}.x",
                message.get("headerId"),
            )
            return
        long = long_id(message)
        if long is not None:
            self._bad(
                kind, f"an id longer than {MAX_ID} characters: {long}", message.get("headerId")
            )
            return
        if (message["manufacturer"], message["serialNumber"]) != (
            self.vehicle.manufacturer,
            self.vehicle.serial_number,
        ):
            # The broker should not have given it to us (docs/fleet-deployment.md's ACL).
            self.bad += 1
            self._unnoted += 1
            return
        if kind is Topic.ORDER:
            self.run.take_order(message)
        else:
            for action in message["actions"]:
                self.actions.take(action)

    def _bad(self, kind: Topic, why: str, header: Any = None) -> None:
        self.bad += 1
        self._unnoted += 1
        references = (("topic", kind.value),) + (
            (("headerId", str(header)),) if header is not None else ()
        )
        self.run.warn(
            Error(
                ErrorType.VALIDATION, ErrorLevel.WARNING, f"{kind.value} refused: {why}", references
            )
        )

    def _note_trouble(self) -> None:
        now = time.monotonic()
        if now - self._noted_at < NOTE_GAP_S:
            return
        self._noted_at = now
        self._note(
            f"fleet: {self.bad} messages refused and {self.dropped} dropped (a "
            f"flood) so far; {self._unnoted} since the last line"
        )
        self._unnoted = 0

    # -- what the vehicle says ----------------------------------------------------------

    def facts(self) -> VehicleFacts:
        extra: tuple[Error, ...] = ()
        now = time.monotonic()
        if self.dropped != self._dropped_seen[0]:
            self._dropped_seen = (self.dropped, now)
        # Said while messages are being dropped, and a while after.
        if self.dropped and now - self._dropped_seen[1] < FLOOD_SAID_S:
            extra = (
                Error(
                    ErrorType.FLOOD,
                    ErrorLevel.WARNING,
                    f"{self.dropped} messages dropped: more came than the vehicle "
                    f"reads ({INBOX_SIZE} waiting at most)",
                ),
            )
        navigator = self.service.navigator
        return self.run.facts(navigator.plan.name if navigator is not None else "", extra)

    def _send_state(self) -> None:
        # Not before the loop's first snapshot: a state says where the robot is.
        if not self._connection or self.service.telemetry is None:
            return
        facts = self.facts()
        # Everything but where the robot is: a change of it is said at once.
        signature = (
            facts.progress,
            facts.mode,
            facts.paused,
            facts.driving,
            facts.errors,
            facts.actions,
            facts.room,
            facts.information,
            facts.telemetry.battery if facts.telemetry is not None else None,
            facts.telemetry.state.estop
            if facts.telemetry is not None and facts.telemetry.state is not None
            else None,
        )
        now = time.monotonic()
        changed = signature != self._last and now - self._sent_at >= MIN_STATE_GAP_S
        if not changed and now - self._sent_at < STATE_PERIOD_S:
            return
        self._last, self._sent_at = signature, now
        self._publish(Topic.STATE, state_body(facts))
        self._publish(Topic.VISUALIZATION, visualization_body(facts))

    def _publish_factsheet(self) -> None:
        self._publish(Topic.FACTSHEET, factsheet(self.settings), retain=True, qos=1)

    def _publish(
        self, kind: Topic, body: dict[str, Any], *, retain: bool = False, qos: int = 0
    ) -> None:
        payload = encode(self.headers.stamp(kind, body))
        self.link.publish(self.vehicle.topic(kind), payload, retain=retain, qos=qos)

    def _connection_message(self, state: ConnectionState) -> bytes:
        return encode(self.headers.stamp(Topic.CONNECTION, {"connectionState": state.value}))

    def _note(self, text: str) -> None:
        self.service.note(text)
