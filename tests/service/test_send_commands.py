"""Controller commands asked of the robot service together (c.SendCommands), as
`giraff-console send` asks them: checked all on the loop's thread before any is sent,
answered with the board's decoded replies, typed (Sent), in-process and on the wire.

The loop is ticked by the test on a virtual clock while the request waits on another
thread, as a front end's would.
"""

from __future__ import annotations

import math
import threading

import pytest

from giraff_console.link import BoardLink, Exchange
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol import BoardError
from giraff_console.robot.teleop import DriveLimits
from giraff_console.service import command_batch, wire
from giraff_console.service import commands as c
from giraff_console.service import daemon as _registers_the_wire_types  # noqa: F401
from giraff_console.service.events import Answer, Reply, SendEnd, Sent
from giraff_console.service.robot_service import HERE, RobotService
from tests.missions.site import PLAN, TICK, Site

# The issue's attack: 5 m at 0.6 m/s, after `send` has exited.
ATTACK = ("set r 1000", "set mode 0", "set v 0.6", "set a 0.1", "set vg 0", "set p 5")
# Settings within the limits, and a move within the reach.
SAFE_MOVE = ("set r 1000", "set mode 0", "set v 0.3", "set a 0.5", "set vg 0", "set p 0.2")
LIMITS = DriveLimits()


class Rig:
    """The service on a simulated board whose loop the test ticks; what went on the wire."""

    def __init__(self) -> None:
        self.site = Site(Navigator(PLAN, walls_of(PLAN)))
        self.service = RobotService(self.site.control, DriveSetup.on_loop(
            self.site.control, self.site.navigator))  # fmt: skip
        self.sent: list[str] = []
        self.site.control.subscribe(self._heard)

    def _heard(self, event: object) -> None:
        if isinstance(event, Exchange) and not event.automatic:
            self.sent.append(event.command)

    @property
    def link(self) -> BoardLink:
        return self.site.link

    def ask(self, *texts: str, console: str = HERE) -> Reply:
        """SendCommands(texts), answered while the loop ticks."""
        replies: list[Reply] = []
        asking = threading.Thread(
            target=lambda: replies.append(self.service.execute(c.SendCommands(texts), console))
        )
        asking.start()
        while asking.is_alive():
            self.tick()
            asking.join(0.002)
        return replies[0]

    def tick(self, seconds: float = TICK) -> None:
        end = self.site.clock.now() + seconds
        while self.site.clock.now() < end:
            self.site.control.tick()
            self.site.clock.advance(TICK)

    def travel_after(self, seconds: float) -> float:
        """How far the robot really goes in the next `seconds`, the loop ticking."""
        start = self.site.true_pose()
        self.tick(seconds)
        end = self.site.true_pose()
        return math.hypot(end.x - start.x, end.y - start.y)


@pytest.fixture
def rig() -> Rig:
    return Rig()


def test_the_issue_s_attack_is_refused_and_nothing_is_sent(rig):
    reply = rig.ask(*ATTACK)
    assert not reply.ok
    assert reply.sent is not None and reply.sent.end is SendEnd.REFUSED
    assert reply.sent.answers == ()
    assert "refused: set v 0.6" in reply.sent.why
    assert rig.sent == []
    assert rig.travel_after(20) < 1e-6


def test_an_accepted_move_is_answered_and_stays_within_the_runaway_limit(rig):
    reply = rig.ask(*SAFE_MOVE)
    assert reply.ok, reply
    assert reply.sent is not None and reply.sent.end is SendEnd.ANSWERED
    assert [answer.command for answer in reply.sent.answers] == list(SAFE_MOVE)
    assert rig.sent == list(SAFE_MOVE)
    # Typed values, not text: the board's float32 answer to `set v 0.3`.
    assert reply.sent.answers[2].value == pytest.approx(0.3)
    assert 0.19 < rig.travel_after(20) <= LIMITS.runaway


def test_the_loop_s_own_settings_are_the_ones_a_move_is_checked_by(rig):
    # The loop set r, mode 0, v, a and vg within the limits as it connected, and the
    # guard knows them: a move alone goes, as it does from the console's command line.
    reply = rig.ask("set p 0.2", "get bulk_data")
    assert reply.ok, reply
    bulk = reply.sent.answers[1].value
    assert isinstance(bulk, dict) and bulk["mode"] & 128  # MOVING


def test_each_command_is_checked_as_the_earlier_ones_leave_the_board(rig):
    # A curve that gears the outer wheel 1.3 times: 0.25 m in the middle is 0.325 m on
    # it, beyond the reach; straight, the same target is within it.
    curved = rig.ask("set vg 0.3", "set r 1000", "set p 0.25")
    assert curved.sent.end is SendEnd.REFUSED and "outer wheel" in curved.sent.why
    assert rig.sent == []
    straight = rig.ask("set vg 0", "set r 1000", "set p 0.25")
    assert straight.ok, straight


def test_nothing_is_sent_when_a_later_command_is_refused(rig):
    reply = rig.ask("set v 0.3", "home", "reset")
    assert reply.sent.end is SendEnd.REFUSED and "refused: reset" in reply.sent.why
    assert rig.sent == []


def test_nothing_is_sent_after_a_board_error(rig):
    # The thesis's board has no height stalk: a reading the guard knows, the board not.
    reply = rig.ask("get v", "get h", "get a")
    assert reply.sent.end is SendEnd.BOARD_REFUSED
    assert rig.sent == ["get v", "get h"]
    answered, refused = reply.sent.answers
    assert answered.error is None and refused.command == "get h"
    assert isinstance(refused.error, BoardError)


def test_a_watcher_may_read_but_a_set_needs_the_controls(rig):
    service = rig.service
    service.attach("holder")
    service.attach("watcher")
    assert rig.ask("get v", "GET bulk_data", console="watcher").ok
    refused = rig.ask("set v 0.3", console="watcher")
    assert not refused.ok and refused.sent is None and "holder holds the controls" in refused.text
    assert rig.sent == ["get v", "get bulk_data"]
    assert rig.ask("set v 0.3", console="holder").ok


def test_a_get_goes_beside_a_mission_but_a_set_does_not(rig):
    assert rig.service.execute(c.Go("room-101")).ok
    rig.tick(1.0)
    assert rig.site.control.mission is not None
    read = rig.ask("get bulk_data")
    assert read.ok, read
    meddling = rig.ask("set v 0.1")
    assert meddling.sent.end is SendEnd.REFUSED
    assert "not while go room-101 runs" in meddling.sent.why
    assert "set v 0.1" not in rig.sent
    assert rig.site.control.mission is not None  # still on its way


def test_a_batch_the_loop_did_not_take_in_time_is_never_sent(rig, monkeypatch):
    monkeypatch.setattr(command_batch, "TAKE_WAIT_S", 0.01)
    # Nobody ticks the loop: the asker gives up and is told nothing was sent ...
    reply = rig.service.execute(c.SendCommands(("set v 0.3",)))
    assert reply.sent.end is SendEnd.NO_LINK and "not sent" in reply.sent.why
    # ... and the loop, when it comes to it, sends nothing.
    rig.tick(0.5)
    assert rig.sent == []


def test_too_many_or_malformed_commands_are_refused_before_the_loop_sees_them(rig):
    many = rig.service.execute(c.SendCommands(("get v",) * (c.MAX_COMMANDS + 1)))
    assert many.sent.end is SendEnd.REFUSED
    none = rig.service.execute(c.SendCommands(()))
    assert none.sent.end is SendEnd.REFUSED
    garbled = rig.service.execute(c.SendCommands(("get v\rset p 9",)))
    assert garbled.sent.end is SendEnd.REFUSED
    assert rig.sent == []


def test_a_board_that_restarted_leaves_its_settings_unknown_to_the_guard(rig):
    rig.tick(0.2)
    assert rig.site.control.teleop.board_settings  # set as the loop connected
    rig.link.port.dtr = False
    rig.link.port.dtr = True  # the board reboots: back at v = a = 0.6, vg = 1
    # The batch finds it (jobs go before the tick's poll): the loop is told, and the
    # guard no longer takes the old settings for the board's.
    reply = rig.ask("get v")
    assert reply.sent.end is SendEnd.BOARD_RESTARTED, reply
    assert rig.site.control.teleop.board_settings == {}
    move = rig.ask("set p 0.2")
    assert move.sent.end is SendEnd.REFUSED and "unknown" in move.sent.why


def test_what_came_of_them_crosses_the_daemon_s_socket_as_it_is():
    sent = Sent(SendEnd.BOARD_REFUSED, (
        Answer("get bulk_data", {"cang": 0.0, "mode": 128}, ("cang 0", "mode 128")),
        Answer("get v", 0.30000001192092896, ("F*9a99993e",)),
        Answer("set h 5", None, ("OK",)),
        Answer("get nonsense", error=BoardError("Unknown name: nonsense")),
    ), "board error: Unknown name: nonsense")  # fmt: skip
    reply = Reply(False, sent.why, sent=sent)
    back = wire.decode(wire.encode(reply))
    assert isinstance(back, Reply) and back.sent is not None
    assert back.sent.end is SendEnd.BOARD_REFUSED
    assert back.sent.answers[:3] == sent.answers[:3]
    error = back.sent.answers[3].error
    assert isinstance(error, BoardError) and str(error) == str(sent.answers[3].error)
    assert back.sent.answers[0].value == {"cang": 0.0, "mode": 128}
    assert isinstance(back.sent.answers[0].value["mode"], int)


def test_an_operator_s_stop_during_the_commands_keeps_the_rest_from_going(rig):
    """The operator's stop wins over a batch (review of issue 26): a halt that comes while
    the batch goes out leaves the rest unsent, and the robot stopped."""
    halted = threading.Event()

    def halt_after_the_first_move(event: object) -> None:
        if isinstance(event, Exchange) and event.command == "set p 0.2" and not halted.is_set():
            halted.set()
            rig.service.execute(c.Halt())

    rig.site.control.subscribe(halt_after_the_first_move)
    reply = rig.ask(*SAFE_MOVE, "get bulk_data", "set p 0.2")
    assert reply.sent is not None and reply.sent.end is SendEnd.STOPPED
    assert [answer.command for answer in reply.sent.answers] == list(SAFE_MOVE)
    assert "the operator's stop came first" in reply.sent.why
    assert rig.sent.count("set p 0.2") == 1
    assert rig.travel_after(2.0) < 0.2


def test_reads_alone_go_one_a_tick_so_that_the_loop_ticks_between_them(rig):
    ticks_between: list[int] = []
    ticks = [0]

    def heard(event: object) -> None:
        if isinstance(event, Exchange) and event.command == "get v" and not event.automatic:
            ticks_between.append(ticks[0])

    def counted_tick() -> None:
        ticks[0] += 1
        tick()

    tick = rig.site.control.tick
    rig.site.control.tick = counted_tick
    rig.site.control.subscribe(heard)
    reply = rig.ask(*["get v"] * 5)
    assert reply.sent is not None and reply.sent.end is SendEnd.ANSWERED
    assert len(reply.sent.answers) == 5
    assert len(set(ticks_between)) == 5  # each in a tick of its own


def test_a_failure_of_the_console_s_own_is_told_at_once_not_waited_for(rig, monkeypatch):
    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("a bug")

    monkeypatch.setattr(command_batch, "send_in_order", broken)
    reply = rig.ask("get v")
    assert reply.sent is not None and reply.sent.end is SendEnd.FAILED
