"""Every way the console can end or fail reaches the loop as "stop now" (design.md):
nothing but the stop goes out after it, and the stop comes from a fresh poll."""

from __future__ import annotations

import math

import pytest

from giraff_console.link import Exchange
from giraff_console.missions.undock import Undock
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.board_gauges import READ_EVERY_S
from giraff_console.robot.deadman import Intent
from giraff_console.robot.last_stop import LastStop
from giraff_console.robot.loop_events import ExchangeTap
from giraff_console.robot.safety import REACH_M
from tests.robot.test_missions import Ahead, Loop
from tests.robot.test_odometry_firmware import TICK, Console, Straight


def sent_after(loop: Loop, action) -> list[str]:
    """The commands the loop sends to the board from `action` on."""
    sent: list[str] = []

    def watch(exchange: Exchange) -> None:
        if exchange.kind == "set":
            sent.append(exchange.command)

    loop.control.subscribe(ExchangeTap(watch))
    action()
    return sent


def travel_from(loop: Loop, seconds: float) -> float:
    """How far the robot really goes in the next `seconds`, the loop ticking on."""
    before = loop.board.true_pose
    loop.run(seconds)
    after = loop.board.true_pose
    return math.dist((before.x, before.y), (after.x, after.y))


def cruising(loop: Loop, mission: Ahead) -> None:
    loop.start(mission)
    loop.run(2.0)
    assert loop.board.true_pose.x > 0.4  # going at 0.4 m/s by now


def test_an_emergency_stop_ends_the_mission_and_stops_the_robot_on_the_next_tick():
    loop = Loop()
    mission = Ahead()
    cruising(loop, mission)
    sent = sent_after(loop, lambda: (loop.control.emergency_stop("SIGHUP received"),
                                     loop.run(0.05)))  # fmt: skip
    assert loop.control.mission is None
    assert "ahead stopped: SIGHUP received" in loop.notes
    # The stop, worked out from the speed just polled: the braking distance, no more.
    assert sent[-1].startswith("set p ") and float(sent[-1].split()[-1]) < 0.2
    assert "set p 0.24" not in sent
    assert travel_from(loop, 3.0) < 0.2


def test_no_renewal_goes_out_once_the_stop_was_asked_for_mid_tick():
    loop = Loop()

    class SignalledMidTick(Ahead):
        # The signal comes while the tick is working out what to send.
        def step(self, now, state):
            commands = super().step(now, state)
            if now >= 2.0:
                loop.control.emergency_stop("SIGTERM received")
            return commands

    cruising(loop, SignalledMidTick())
    sent = sent_after(loop, lambda: loop.run(0.5))
    assert "set p 0.24" not in sent
    assert loop.control.mission is None
    assert travel_from(loop, 3.0) < REACH_M


def test_no_gauge_is_read_once_the_stop_was_asked_for_mid_tick():
    console = Console("later")  # a board with a charger and a stalk, read every 0.5 s
    seen: list[tuple[float, str]] = []
    console.link.add_observer(lambda e: seen.append((console.clock.now(), e.command)))
    asked: list[int] = []  # where in `seen` the stop was asked for

    class SignalledWhenTheGaugesAreDue(Straight):
        def step(self, now, state):
            reads = [at for at, command in seen if command == "get charger_data"]
            if not asked and reads and now >= reads[-1] + READ_EVERY_S:
                console.loop.emergency_stop("SIGTERM received")
                asked.append(len(seen))
            return super().step(now, state)

    console.run(TICK)
    console.loop.run_mission(SignalledWhenTheGaugesAreDue())
    give_up = console.clock.now() + 2.0
    while not asked:
        assert console.clock.now() < give_up
        console.run(TICK)
    after = [command for _, command in seen[asked[0] :]]
    assert "get charger_data" not in after and "get h" not in after
    console.run(TICK)  # the next tick stops the robot
    assert console.loop.mission is None


def test_closing_after_the_stop_releases_the_port():
    loop = Loop()
    cruising(loop, Ahead())
    loop.control.emergency_stop("SIGTERM received", close=True)
    loop.run(0.05)
    assert loop.control.wait_closed(0)
    assert loop.control.link is None
    assert not loop.port.is_open
    assert travel_from(loop, 3.0) < 0.2


def test_an_exception_elsewhere_stops_the_robot_before_anything_else():
    loop = Loop()
    cruising(loop, Ahead())
    LastStop(loop.control).crashed(UnicodeDecodeError("utf-8", b"\xff", 0, 1, "bad"))
    loop.run(0.05)
    assert loop.control.mission is None
    assert any("internal error (UnicodeDecodeError)" in note for note in loop.notes)
    assert travel_from(loop, 3.0) < 0.2


def rolling_over(loop: Loop) -> None:
    """From now on the board answers every `set p` with "ERROR: Queue rollover"."""
    loop.board.drive.queue_move = lambda now: False


def test_a_board_that_refuses_every_move_ends_the_mission_instead_of_being_asked_again():
    loop = Loop()
    cruising(loop, Ahead())
    rolling_over(loop)
    sent = sent_after(loop, lambda: loop.run(2.0))
    assert sent.count("set p 0.24") == 1
    assert loop.control.mission is None
    assert any(note.startswith("ahead stopped: the board refused set p 0.24")
               for note in loop.notes)  # fmt: skip


def test_a_board_that_refuses_the_held_key_stops_the_driving():
    loop = Loop()
    loop.control.tick()
    rolling_over(loop)
    sent = sent_after(loop, lambda: hold_forward(loop, 1.0))
    assert sum(command.startswith("set p ") for command in sent) == 1
    assert any(note.startswith("driving stopped: set p ") for note in loop.notes)


def hold_forward(loop: Loop, seconds: float) -> None:
    for _ in range(round(seconds / 0.05)):
        loop.control.press(Intent.FORWARD)
        loop.control.tick()
        loop.clock.advance(0.05)


def test_undock_is_streamed_within_the_reach_never_queued_on_the_board():
    # The board's own undock runs 0.784 m that a dead console cannot stop (A.4.9).
    loop = Loop()
    loop.control.tick()
    start = loop.board.true_pose
    sent = sent_after(loop, lambda: (loop.start(Undock(0.3)), loop.run(15.0)))
    assert not any(command.startswith("set undock") for command in sent)
    assert loop.notes[-1] == "undock done"
    end = loop.board.true_pose
    assert math.dist((start.x, start.y), (end.x, end.y)) == pytest.approx(0.3, abs=0.01)
    assert abs(abs(end.heading - start.heading) - math.pi) < math.radians(2)
    # Each target within the reach: metres backing out, degrees turning (A.2.2).
    style = "1"
    for command in sent:
        name, value = command.split()[1:]
        if name == "r":
            style = value
        if name == "p":
            reach = REACH_M * TURN_FACTOR_DEG_PER_M if style == "0" else REACH_M
            assert abs(float(value)) <= reach


def test_last_stop_leaves_the_process_as_it_found_it_when_uninstalled():
    # The CLI called in-process (as tests do) must not leave signals blocked behind it.
    import signal
    import sys
    import threading

    before = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    hooks = threading.excepthook, sys.excepthook
    last_stop = LastStop(Loop().control, exit=lambda code: None)
    last_stop.install()
    assert signal.SIGTERM in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    last_stop.uninstall()
    assert signal.pthread_sigmask(signal.SIG_BLOCK, []) == before
    assert (threading.excepthook, sys.excepthook) == hooks
    assert not any(thread.name == "last-stop" for thread in threading.enumerate())
