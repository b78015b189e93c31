"""The control loop's one stream of events: who subscribes hears everything, and nobody
who listens can stop the robot being driven."""

from __future__ import annotations

import logging
import math
import sys
import threading
from collections.abc import Iterator

import pytest

from giraff_console.link import BoardLink, Exchange
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.loop_events import ExchangeTap, LoopEvent, Note
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.robot.teleop import Teleop

TICK = 0.05
# Real seconds to wait for a loop running on its own thread; never reached when it works.
PATIENCE_S = 30.0


class Heard:
    """A listener that keeps everything it is told."""

    def __init__(self) -> None:
        self.events: list[LoopEvent] = []

    def __call__(self, event: LoopEvent) -> None:
        self.events.append(event)

    def of(self, kind: type) -> list:
        return [event for event in self.events if isinstance(event, kind)]


class Loop:
    """A control loop on a simulated board on a virtual clock, stepped by hand."""

    def __init__(self) -> None:
        self.link = BoardLink.open("giraff-sim://?clock=virtual")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.control = ControlLoop(
            lambda: self.link, teleop=Teleop(), deadman=Deadman(self.clock), clock=self.clock
        )

    def run(self, ticks: int) -> None:
        for _ in range(ticks):
            self.control.tick()
            self.clock.advance(TICK)


@pytest.fixture
def loop() -> Loop:
    return Loop()


def test_a_listener_gets_one_snapshot_each_tick(loop):
    heard = Heard()
    loop.control.subscribe(heard)
    loop.run(10)
    snapshots = heard.of(Telemetry)
    assert len(snapshots) == 10
    assert snapshots[-1].link is LinkState.CONNECTED


def test_a_listener_gets_the_loop_s_notes_and_its_exchanges_with_the_board(loop):
    heard = Heard()
    loop.control.subscribe(heard)
    loop.run(3)
    loop.control.note("a line for the operator")
    assert any(note.text.startswith("connected to") for note in heard.of(Note))
    assert heard.of(Note)[-1] == Note("a line for the operator")
    assert "get bulk_data" in [exchange.command for exchange in heard.of(Exchange)]


def test_every_listener_hears_the_same_events_in_the_same_order(loop):
    first, second = Heard(), Heard()
    loop.control.subscribe(first)
    loop.control.subscribe(second)
    loop.run(5)
    assert first.events and first.events == second.events


def test_an_exchange_tap_hands_on_the_exchanges_alone(loop):
    exchanges: list[Exchange] = []
    loop.control.subscribe(ExchangeTap(exchanges.append))
    loop.run(3)
    assert exchanges and all(isinstance(exchange, Exchange) for exchange in exchanges)


def test_an_unsubscribed_listener_hears_nothing_more(loop):
    heard = Heard()
    loop.control.subscribe(heard)
    loop.run(3)
    loop.control.unsubscribe(heard)
    before = len(heard.events)
    loop.run(3)
    loop.control.note("after")
    assert len(heard.events) == before


def test_an_exchange_tap_made_again_unsubscribes_the_one_subscribed(loop):
    exchanges: list[Exchange] = []
    loop.control.subscribe(ExchangeTap(exchanges.append))
    loop.run(2)
    loop.control.unsubscribe(ExchangeTap(exchanges.append))
    before = len(exchanges)
    loop.run(3)
    assert before and len(exchanges) == before


def test_unsubscribing_a_listener_never_subscribed_changes_nothing(loop):
    heard = Heard()
    loop.control.subscribe(heard)
    loop.control.unsubscribe(Heard())
    loop.run(2)
    assert len(heard.of(Telemetry)) == 2


def test_a_listener_that_fails_stops_neither_the_loop_nor_the_others(loop, caplog):
    def broken(event: LoopEvent) -> None:
        raise RuntimeError("a listener with a bug")

    heard = Heard()
    loop.control.subscribe(broken)
    loop.control.subscribe(heard)
    sent: list[str] = []
    loop.link.add_observer(lambda exchange: sent.append(exchange.command))
    with caplog.at_level(logging.ERROR, logger="giraff_console.robot.control_loop"):
        loop.run(3)
        loop.control.note("still heard")
        for _ in range(10):  # the key held: the robot is still driven
            loop.control.press(Intent.FORWARD)
            loop.run(1)
    assert len(heard.of(Telemetry)) == 13
    assert Note("still heard") in heard.of(Note)
    assert any(command.startswith("set p") for command in sent)
    assert loop.board.true_pose.x > 0.0
    assert "listener failed" in caplog.text
    # A failure is not a crash of the tick: the loop never stopped the robot for it.
    assert not [note for note in heard.of(Note) if "internal error" in note.text]


def test_a_vital_listener_that_fails_stops_the_robot(loop, caplog):
    # The screen, or standard error without it: once the operator cannot be told what
    # the robot does, it must not go on driving.
    heard = Heard()
    failing = [False]

    def screen(event: LoopEvent) -> None:
        if failing[0]:
            raise RuntimeError("the screen is gone")

    loop.control.subscribe(screen, vital=True)
    loop.control.subscribe(heard)
    for _ in range(20):
        loop.control.press(Intent.FORWARD)
        loop.run(1)
    assert loop.board.true_pose.x > 0.05  # driving
    failing[0] = True
    with caplog.at_level(logging.ERROR, logger="giraff_console.robot.control_loop"):
        for _ in range(40):  # the key still held
            loop.control.press(Intent.FORWARD)
            loop.run(1)
        stopped_at = loop.board.true_pose.x
        for _ in range(20):
            loop.control.press(Intent.FORWARD)
            loop.run(1)
    assert loop.board.true_pose.x == pytest.approx(stopped_at, abs=1e-6)
    assert any("can no longer be told" in note.text for note in heard.of(Note))
    # Logged the first time and every 20th, not at every event (the screen fails on
    # every one the other listener heard after it began to).
    logged = caplog.text.count("listener failed")
    assert 1 <= logged <= len(heard.events) // 20 + 1 < len(heard.events) // 2


@pytest.fixture
def running(loop) -> Iterator[Loop]:
    """The loop on its own thread, moving its virtual clock on as fast as it can."""
    switch = sys.getswitchinterval()  # the loop shortens it for the whole process
    loop.control.start(stepped=math.inf)
    try:
        yield loop
    finally:
        assert loop.control.stop()
        sys.setswitchinterval(switch)


def test_listeners_subscribed_from_other_threads_while_the_loop_runs_are_all_heard(running):
    threads, per_thread = 4, 25
    listeners = [[Heard() for _ in range(per_thread)] for _ in range(threads)]
    go = threading.Barrier(threads)

    def subscribe_all(mine: list[Heard]) -> None:
        go.wait(PATIENCE_S)  # all at once, to race one another and the loop
        for heard in mine:
            running.control.subscribe(heard)

    workers = [threading.Thread(target=subscribe_all, args=(mine,)) for mine in listeners]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(PATIENCE_S)
    # One subscribed after them all hears a snapshot: so do they, none lost in the race.
    last = threading.Event()
    running.control.subscribe(lambda event: last.set() if isinstance(event, Telemetry) else None)
    assert last.wait(PATIENCE_S)
    assert all(heard.of(Telemetry) for mine in listeners for heard in mine)


def test_a_listener_unsubscribed_from_another_thread_hears_at_most_the_event_under_way(running):
    heard = Heard()
    running.control.subscribe(heard)
    ticks = threading.Semaphore(0)
    running.control.subscribe(
        lambda event: ticks.release() if isinstance(event, Telemetry) else None
    )
    assert ticks.acquire(timeout=PATIENCE_S)
    running.control.unsubscribe(heard)
    before = len(heard.events)
    for _ in range(3):
        assert ticks.acquire(timeout=PATIENCE_S)
    assert len(heard.events) <= before + 1
