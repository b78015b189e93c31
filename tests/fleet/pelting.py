"""Hostile messages (tests/fleet/hostile.py) sent to one running vehicle, and what became
of each: read and refused by the vehicle, dropped and counted (its inbox full, or over
the link's size), or, on its own topics, never read. Shared by tests/fleet/test_hostile.py
and bench/fleet_hostile.py.

It watches the vehicle from inside the process, as only a test may: every message the
vehicle's thread reads (its `_read`), everything it publishes (its link's `publish`),
every note and mission of its robot (the service's events), and the simulator's true
pose.
"""

from __future__ import annotations

import itertools
import json
import math
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import paho.mqtt.client as mqtt

from giraff_console.fleet.broker_link import MAX_MESSAGE_BYTES
from giraff_console.fleet.schemas import problem
from giraff_console.fleet.topics import Topic
from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.service.events import ServiceEvent
from tests.fleet.fleet_site import FleetRobot
from tests.fleet.hostile import Hostile

# Below the vehicle's inbox (INBOX_SIZE 64): paced, so that most are read.
BURST = 32
CATCH_UP_S = 20.0


@dataclass
class Figures:
    """What became of one kind's messages."""

    kind: str
    sent: int = 0
    read: int = 0  # taken from the inbox by the vehicle's thread
    refused: int = 0  # of those, refused (vehicle.bad)
    dropped: int = 0  # the inbox full (vehicle.dropped)
    too_big: int = 0  # over MAX_MESSAGE_BYTES (link.dropped)
    elsewhere: int = 0  # on topics the vehicle does not read, heard by another client
    # A flood only: never delivered to the vehicle; the broker drops QoS 0 messages for a
    # client that does not read them fast enough (Mosquitto's max_queued_messages).
    lost_at_broker: int = 0
    seconds: float = 0.0
    internal_errors: int = 0  # notes of an exception in the vehicle's thread
    missions: int = 0  # missions started
    moved_m: float = 0.0  # the true pose's farthest from where it was
    turned_rad: float = 0.0
    largest_state: int = 0  # bytes
    invalid_states: list[str] = field(default_factory=list)
    longest_state_gap_s: float = 0.0

    @property
    def acted_on(self) -> int:
        """Read, well formed and for this vehicle: handed to the order's run."""
        return self.read - self.refused

    def line(self) -> str:
        rate = self.read / self.seconds if self.seconds else 0.0
        return (
            f"{self.kind:15} sent {self.sent:6} read {self.read:6} ({rate:6.0f}/s) refused "
            f"{self.refused:6} acted on {self.acted_on:5} dropped {self.dropped:5} "
            f"too big {self.too_big:3} elsewhere {self.elsewhere:6} lost at the broker "
            f"{self.lost_at_broker:5} in {self.seconds:5.1f} s | "
            f"internal errors {self.internal_errors} missions {self.missions} moved "
            f"{self.moved_m * 1000:.2f} mm largest state {self.largest_state} B, gap "
            f"{self.longest_state_gap_s:.2f} s"
        )


class Pelting:
    """Watches one vehicle and sends it hostile messages; `close` it."""

    def __init__(self, robot: FleetRobot, port: int) -> None:
        self.robot = robot
        vehicle = robot.vehicle
        self.reads = 0
        self.notes: list[str] = []
        self.missions: list[MissionChanged] = []
        self.states: list[tuple[float, bytes]] = []  # what the vehicle published, when
        self._published: set[bytes] = set()
        self.elsewhere = 0  # heard by the side listener, not published by the vehicle
        self._heard_topics: set[str] = set()
        self._lock = threading.Lock()
        read, publish = vehicle._read, vehicle.link.publish

        def counted_read(topic: str, payload: bytes) -> None:
            self.reads += 1  # only the vehicle's thread writes it
            read(topic, payload)

        def spied_publish(topic: str, payload: bytes, **options: Any) -> bool:
            with self._lock:
                self._published.add(payload)
                if topic == vehicle.vehicle.topic(Topic.STATE):
                    self.states.append((time.monotonic(), payload))
            return publish(topic, payload, **options)

        vehicle._read = counted_read  # type: ignore[method-assign]
        vehicle.link.publish = spied_publish  # type: ignore[method-assign]
        robot.robot.service.subscribe(self._heard)
        self._sender = self._client("hostile-sender")
        self._listener = self._client("hostile-listener")
        self._listener.on_message = self._on_message
        self._listener.connect("127.0.0.1", port)
        for kind in (Topic.STATE, Topic.CONNECTION, Topic.FACTSHEET, Topic.VISUALIZATION):
            self._listener.subscribe(vehicle.vehicle.topic(kind), qos=0)
        self._listener.loop_start()
        self._sender.connect("127.0.0.1", port)
        self._sender.loop_start()
        # The vehicle said its connection and factsheet (retained) before the spy above
        # was in place: heard late, under load, they were counted as a hostile message
        # heard elsewhere during the first sending (a flood's accounting one over).
        # Whether retained or live, each comes once: wait for both before any sending.
        said = {vehicle.vehicle.topic(Topic.CONNECTION), vehicle.vehicle.topic(Topic.FACTSHEET)}
        deadline = time.monotonic() + CATCH_UP_S
        while not said <= self._topics_heard():
            assert time.monotonic() < deadline, "the vehicle's retained messages never came"
            time.sleep(0.01)

    def listen(self, topics: Iterable[str]) -> None:
        """Hear these topics too (ones the vehicle must not), to count what arrives."""
        for topic in topics:
            self._listener.subscribe(topic, qos=0)
        time.sleep(0.3)  # the broker has taken the subscriptions

    @staticmethod
    def _client(name: str) -> mqtt.Client:
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=name)
        client.suppress_exceptions = True  # nothing it hears may end its thread
        return client

    def close(self) -> None:
        self.robot.robot.service.unsubscribe(self._heard)
        for client in (self._sender, self._listener):
            client.disconnect()
            client.loop_stop()

    def _heard(self, event: ServiceEvent) -> None:
        if isinstance(event, Note):
            self.notes.append(event.text)
        elif isinstance(event, MissionChanged) and event.running:
            self.missions.append(event)

    def _on_message(self, client: mqtt.Client, userdata: object, message: mqtt.MQTTMessage) -> None:
        with self._lock:
            self._heard_topics.add(message.topic)
            if message.payload not in self._published:
                self.elsewhere += 1

    def _topics_heard(self) -> set[str]:
        with self._lock:
            return set(self._heard_topics)

    # -- sending ------------------------------------------------------------------------

    def send(
        self, kind: str, messages: Iterable[Hostile], *, burst: int = BURST, read: bool = True
    ) -> Figures:
        """Send them `burst` at a time, each burst after the vehicle has accounted for the
        last (read it, or dropped it); `read` False: on topics the vehicle must not read,
        each burst after the side listener heard it. `burst` 0: all at once, a flood."""
        vehicle = self.robot.vehicle
        # amqtt hangs up on a sender that flooded it (an earlier test's flood): paho's
        # loop connects again by itself, and the next kind is sent once it has.
        deadline = time.monotonic() + CATCH_UP_S
        while not self._sender.is_connected():
            assert time.monotonic() < deadline, f"{kind}: the sender is not connected again"
            time.sleep(0.05)
        start_pose = self.robot.robot.true_pose()
        assert start_pose is not None
        before = (self.reads, vehicle.bad, vehicle.dropped, vehicle.link.dropped, self.elsewhere)
        notes, missions, states = len(self.notes), len(self.missions), len(self.states)
        figures = Figures(kind)
        started = time.monotonic()
        pending: list[mqtt.MQTTMessageInfo] = []

        def accounted() -> int:
            if not read:
                return self.elsewhere - before[4]
            return (
                self.reads
                - before[0]
                + vehicle.dropped
                - before[2]
                + vehicle.link.dropped
                - before[3]
            )

        def moved() -> None:
            pose = self.robot.robot.true_pose()
            assert pose is not None and start_pose is not None
            figures.moved_m = max(
                figures.moved_m, math.dist((start_pose.x, start_pose.y), (pose.x, pose.y))
            )
            figures.turned_rad = max(
                figures.turned_rad, abs(math.remainder(pose.heading - start_pose.heading, math.tau))
            )

        def catch_up() -> None:
            for info in pending:
                try:
                    info.wait_for_publish(CATCH_UP_S)
                except (RuntimeError, ValueError):
                    # A flood only: the broker may hang up on the sender (amqtt does under
                    # load); what it never took is counted as lost there, below.
                    if burst or not read:
                        raise
            pending.clear()
            deadline = time.monotonic() + CATCH_UP_S
            last, still_since = -1, time.monotonic()
            while accounted() < figures.sent:
                if not burst and read:
                    # A flood: what the broker dropped never comes; the rest has come once
                    # the counts stand still for a second.
                    now, count = time.monotonic(), accounted()
                    if count != last:
                        last, still_since = count, now
                    elif now - still_since > 1.0:
                        figures.lost_at_broker = figures.sent - count
                        break
                assert time.monotonic() < deadline, (
                    f"{kind}: {figures.sent - accounted()} of {figures.sent} messages "
                    f"neither read nor dropped in {CATCH_UP_S} s"
                )
                time.sleep(0.001)
            moved()

        for message in messages:
            pending.append(self._sender.publish(message.topic, message.payload, qos=0))
            figures.sent += 1
            if burst and figures.sent % burst == 0:
                catch_up()
        catch_up()
        figures.seconds = time.monotonic() - started
        figures.read = self.reads - before[0]
        figures.refused = vehicle.bad - before[1]
        figures.dropped = vehicle.dropped - before[2]
        figures.too_big = vehicle.link.dropped - before[3]
        figures.elsewhere = self.elsewhere - before[4]
        figures.internal_errors = sum("internal error" in text for text in self.notes[notes:])
        figures.missions = len(self.missions) - missions
        sent_states = self.states[states:]
        for _, payload in sent_states:
            figures.largest_state = max(figures.largest_state, len(payload))
            wrong = problem(Topic.STATE, json.loads(payload))
            if wrong is not None:
                figures.invalid_states.append(wrong)
        times = [started] + [at for at, _ in sent_states] + [time.monotonic()]
        figures.longest_state_gap_s = max(b - a for a, b in itertools.pairwise(times))
        return figures

    def states_since(self, since: float) -> list[tuple[float, dict[str, Any]]]:
        with self._lock:
            return [(at, json.loads(payload)) for at, payload in self.states if at >= since]

    def refusal_noted(self) -> bool:
        return any("messages refused" in text for text in self.notes)


def largest_allowed_state() -> int:
    """A state the master control's own link would still take (it drops larger ones)."""
    return MAX_MESSAGE_BYTES
