"""The virtual motor port (§4.5): a program on a pty, served through the control loop,
with a later board's reset-on-read odometers shared out (issue 15, item 4)."""

from __future__ import annotations

import math
import os
import select
import time
from collections.abc import Callable, Iterator

import pytest

from giraff_console.link import BoardLink, Exchange, MotorState, probe
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.protocol.codec import Command, encode_float
from giraff_console.protocol.errors import BoardError, CommandError, UnknownNameError
from giraff_console.protocol.replies import parse_reply
from giraff_console.robot.command_guard import check_command
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.mission import DRIVING, MissionEnd, Progress
from giraff_console.robot.teleop import Teleop
from giraff_console.service import commands as c
from giraff_console.service import virtual_port
from giraff_console.service.commands import PROGRAM
from giraff_console.service.robot_service import RobotService
from giraff_console.service.shared_readings import SharedReadings, add_to_list
from giraff_console.service.virtual_port import (
    MIN_LINE_S,
    MISSION_RUNNING,
    NOT_DRIVING,
    READS_ONLY,
    VirtualPort,
)
from tests.listening import notes_into, only

pytestmark = pytest.mark.timeout(60)

TICK = 0.05
PROMPT = b"OK >\r\n"
# How long a test waits for any one reply in real time before it fails.
REPLY_WAIT_S = 5.0
BULK_FIELDS = ["cang", "cdis", "gvr", "tilt_angle_from_home", "imdl", "imdr", "cvg", "mode"]


class Creep:
    """A mission that renews a short straight target every tick, forever."""

    name = "creep"
    finished = False
    problem = None
    progress = Progress(name, DRIVING)

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        return [Command("set", "p", 0.2)]

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None: ...

    def resume(self, now: float) -> None: ...


class Bench:
    """A control loop on a simulated board, stepped by hand on the board's virtual
    clock, with its virtual port serving."""

    def __init__(self, firmware: str, link_timeout: float = 1.0) -> None:
        self.link = BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.control = ControlLoop(lambda: self.link, teleop=Teleop(),
                                   deadman=Deadman(self.clock), clock=self.clock)  # fmt: skip
        self.exchanges: list[Exchange] = []
        self.notes: list[str] = []
        self.control.subscribe(only(Exchange, self.exchanges.append))
        self.control.subscribe(notes_into(self.notes))
        self.control.tick()  # connected and probed
        assert self.control.link is not None, self.notes
        self.service = RobotService(self.control, DriveSetup.on_loop(self.control, None))
        self.port = VirtualPort(self.service, link_timeout=link_timeout)
        self.port.start()
        self.driving: Intent | None = None
        self.ended: list[MissionEnd] = []

    def step(self) -> None:
        """A tick at 20 Hz, with the key held as a terminal repeats it, if driving."""
        if self.driving is not None:
            self.control.press(self.driving)
        self.control.tick()
        self.clock.advance(TICK)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / TICK)):
            self.step()

    def sent(self, text: str) -> list[Exchange]:
        return [e for e in self.exchanges if e.command == text]

    def travelled(self) -> float:
        truth = self.board.true_pose
        return math.hypot(truth.x, truth.y)


class Program:
    """Another program on the virtual port, reading and writing its end raw. While it
    waits for a reply it calls `wait` (the loop ticks, without time passing)."""

    def __init__(self, path: str, wait: Callable[[], None] = lambda: None) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.wait = wait
        self.buffer = b""

    def replies(self) -> list[str]:
        """The lines up to the next prompt."""
        give_up = time.monotonic() + REPLY_WAIT_S
        while PROMPT not in self.buffer:
            assert time.monotonic() < give_up, f"no prompt in {REPLY_WAIT_S} s: {self.buffer!r}"
            self.wait()
            if select.select([self.fd], [], [], 0.002)[0]:
                self.buffer += os.read(self.fd, 4096)
        reply, _, self.buffer = self.buffer.partition(PROMPT)
        return [line for line in reply.decode("ascii").split("\r\n") if line]

    def ask(self, line: str) -> list[str]:
        os.write(self.fd, line.encode("ascii") + b"\r")
        return self.replies()

    def bulk(self) -> dict:
        value = parse_reply(self.ask("get bulk_data")).value
        assert isinstance(value, dict)
        return value

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


@pytest.fixture
def later() -> Iterator[Bench]:
    bench = Bench("later")
    yield bench
    assert bench.port.close()
    bench.link.close()


@pytest.fixture
def program(later: Bench) -> Iterator[Program]:
    program = Program(later.port.path, later.control.tick)
    assert program.replies() == [f"# Giraf {later.link.version}"]  # greeted on opening
    yield program
    program.close()


def refusal(command: Command, bench: Bench) -> str:
    """What the guard says to `command`, as a typed command would hear it."""
    teleop = bench.control.teleop
    with pytest.raises(CommandError) as refused:
        check_command(command, teleop.limits, teleop.board_settings)
    return f"Error: refused: {refused.value}"


# -- the protocol -----------------------------------------------------------------------


@pytest.mark.parametrize("firmware", ["thesis", "later"])
def test_a_program_s_get_bulk_data_gets_the_board_s_reply(firmware):
    bench = Bench(firmware)
    program = Program(bench.port.path, bench.control.tick)
    try:
        assert program.replies() == [f"# Giraf {bench.link.version}"]
        (line,) = program.ask("get bulk_data")
        assert line.endswith(",")  # as real boards end a list
        value = parse_reply([line]).value
        assert isinstance(value, dict) and list(value) == BULK_FIELDS
        assert value["tilt_angle_from_home"] == pytest.approx(0.0873, abs=1e-4)
        # It went to the board through the loop, as anyone's read does.
        assert bench.sent("get bulk_data")[-1].lines == (line,)
    finally:
        program.close()
        assert bench.port.close()


def test_a_malformed_line_gets_the_board_s_error_and_the_port_goes_on(later, program):
    assert program.ask("set v abc") == ["Error: Unknown argument"]
    assert program.ask("get") == ["Error: Argument wasn't optional"]
    assert program.ask("frobnicate") == ["Unknown name: frobnicate"]
    assert program.ask("get no_such_reading") == ["Unknown name: no_such_reading"]
    assert program.ask("set v " + "1" * 300) == ["Error: Line too long"]
    assert program.ask("") == []
    assert list(program.bulk()) == BULK_FIELDS
    assert not [e for e in later.exchanges if "abc" in e.command or "frob" in e.command]


def test_our_own_link_connects_to_the_virtual_port_as_to_a_board():
    link = BoardLink.open("giraff-sim://?clock=virtual&firmware=later")
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(link.port.clock),
                          clock=link.port.clock)  # fmt: skip
    control.start(stepped=1.0)  # the loop on its own thread, as in the daemon
    port = VirtualPort(RobotService(control, DriveSetup.on_loop(control, None)))
    port.start()
    try:
        client = BoardLink.open(port.path, timeout=2.0)
        assert client.version == link.version  # the real board's banner
        assert isinstance(client.bulk(), MotorState)
        assert probe(client) == control.board  # the same board, as far as it can tell
        assert client.set("v", 0.3) == pytest.approx(0.3)
        with pytest.raises(UnknownNameError):
            client.get("nothing")
        ended: list[MissionEnd] = []
        control.run_mission(Creep(), ended.append)
        give_up = time.monotonic() + REPLY_WAIT_S
        while control.mission is None:
            assert time.monotonic() < give_up and not ended, ended
            time.sleep(0.01)
        with pytest.raises(BoardError, match="a mission is running; the virtual port may only"):
            client.set("p", 0.15)
        assert isinstance(client.bulk(), MotorState)  # reading goes on
        client.close()
    finally:
        assert port.close()
        assert control.stop()


# -- who may move the robot -------------------------------------------------------------


def test_set_p_during_a_mission_is_refused_and_never_reaches_the_board(later, program):
    later.control.run_mission(Creep(), later.ended.append)
    later.run(1.0)
    assert later.control.mission is not None and later.board.true_pose.x > 0.2
    assert program.ask("set p 0.15") == [f"Error: {MISSION_RUNNING}"]
    assert program.ask("set v 0.3") == [f"Error: {MISSION_RUNNING}"]
    assert program.ask("home") == [f"Error: {MISSION_RUNNING}"]
    assert not later.sent("set p 0.15") and not later.sent("set v 0.3")
    assert list(program.bulk()) == BULK_FIELDS  # it may read
    later.run(0.5)
    assert later.control.mission is not None and not later.ended  # the mission drives on


def test_a_driver_s_stop_and_idle_idioms_change_nothing_during_the_daemon_s_mission(later, program):
    """One deployed driver starts with `set v 0`; the other sends its stop idiom on
    every loop while idle (wire-facts, "What the deployed drivers do"): neither may end
    the daemon's mission (issue 27)."""
    later.control.run_mission(Creep(), later.ended.append)
    later.run(1.0)
    sent = len(later.exchanges)
    for _ in range(3):
        for text in ("set v 0", "set vg 0", "set p 0", "set a 0", "set r 50", "set vgr 0"):
            assert program.ask(text) == [encode_float(float(text.split()[2]))]
        later.run(0.1)
    later.run(0.5)
    assert later.control.mission is not None and not later.ended  # the mission drives on
    assert later.board.true_pose.x > 0.4
    theirs = [e.command for e in later.exchanges[sent:] if not e.automatic]
    assert not [c for c in theirs if c.split()[1:2] in (["v"], ["vg"], ["a"], ["r"], ["vgr"])]
    assert [n for n in later.notes if n == NOT_DRIVING] == [NOT_DRIVING]  # said once


def test_a_stop_from_the_program_stops_its_own_move(later, program):
    assert program.ask("set p 0.25") == [encode_float(0.25)]
    later.run(0.3)
    assert MotorState.from_bulk(program.bulk(), 0.0).moving
    assert program.ask("set p 0") == [encode_float(0.0)]
    later.run(1.5)
    assert not MotorState.from_bulk(program.bulk(), 0.0).moving
    assert later.board.true_pose.x < 0.25
    # The console's braking stop, not a `set p 0` to brake through and come back from.
    assert not later.sent("set p 0")


def test_the_drivers_stop_idiom_brakes_the_program_s_own_move(later, program):
    """Both deployed drivers stop with `set a 0`, `set v 0`, `set p 0` (wire-facts): the
    braking stop must not find the board at v = 0, which would run the move out."""
    assert program.ask("set p 0.25") == [encode_float(0.25)]
    later.run(0.3)
    moving = MotorState.from_bulk(program.bulk(), 0.0)
    assert moving.moving
    stopped_at = later.board.true_pose.x
    for name in ("a", "v", "p"):
        assert program.ask(f"set {name} 0") == [encode_float(0.0)]
    later.run(1.5)
    assert not MotorState.from_bulk(program.bulk(), 0.0).moving
    # Braked from where the stop was asked (about 0.04 m at 0.2 m/s), not run out to 0.25.
    assert later.board.true_pose.x - stopped_at < 0.1
    assert not later.sent("set v 0") and not later.sent("set p 0")


def test_while_the_operator_drives_the_program_may_only_read(later, program):
    later.driving = Intent.FORWARD
    later.run(0.5)
    assert program.ask("set p 0.15") == ["Error: refused: the operator is driving; the "
                                         "virtual port may only read"]  # fmt: skip
    assert not later.sent("set p 0.15")


def test_what_cannot_be_made_safe_is_refused_with_the_guard_s_message(later, program):
    for text, command in (("set undock 1", Command("set", "undock", 1)),
                          ("set mode 1", Command("set", "mode", 1)),
                          ("set enc0 7", Command("set", "enc0", 7))):  # fmt: skip
        assert program.ask(text) == [refusal(command, later)]
        assert not later.sent(text)


def test_values_beyond_the_limits_are_brought_within_them_where_that_is_safe(later, program):
    """The deployed drivers never read a set's reply (wire-facts): a faster speed or a
    further target than the console allows goes at the limit (issue 27)."""
    assert program.ask("set v 5") == [encode_float(0.4)]
    assert later.control.teleop.board_settings["v"] == "0.4"
    assert program.ask("set a 0.2") == [encode_float(0.32)]
    assert program.ask("set p 5") == [encode_float(0.25)]  # the reach
    assert not later.sent("set p 5") and later.sent("set p 0.25")
    later.run(3.0)
    assert later.board.true_pose.x == pytest.approx(0.25, abs=0.01)
    # Within the limits it goes to the board as sent.
    assert program.ask("set v 0.3") == [encode_float(0.3)]
    assert program.ask("set p 0.2") == [encode_float(0.2)]
    later.run(2.0)
    assert later.board.true_pose.x == pytest.approx(0.45, abs=0.01)


def test_after_a_driver_s_stop_a_move_waits_for_a_and_v_again(later, program):
    for name in ("a", "v", "p"):  # how both real drivers stop (wire-facts)
        assert program.ask(f"set {name} 0") == [encode_float(0.0)]
    refused = program.ask("set p 0.2")
    assert refused == ["Error: refused: a was set to 0 to stop the robot; set a again before "
                       "a move"]  # fmt: skip
    program.ask("set a 0.5")
    # The board holds the v = 0 the program sent: no move at zero speed in mode 0.
    assert "v must be above 0" in program.ask("set p 0.2")[0]
    program.ask("set v 0.3")
    assert program.ask("set p 0.2") == [encode_float(0.2)]


def test_idle_settings_go_to_the_board_when_nobody_else_drives(later, program):
    """A driver that believes it set vg 0 must not get a curve (review of issue 27)."""
    later.control.teleop.board_set("vg", "0.3")  # left by someone before
    for text in ("set vg 0", "set vgr 0", "set r 50"):
        program.ask(text)
    assert later.sent("set vg 0") and later.sent("set r 50")
    assert later.control.teleop.board_settings["vg"] == "0"


def test_idle_settings_sent_during_a_mission_go_to_the_board_before_the_next_command(
    later, program
):
    later.control.run_mission(Creep(), later.ended.append)
    later.run(0.5)
    assert later.control.teleop.board_settings["r"] != "50"
    program.ask("set r 50")
    later.run(0.5)
    assert not later.sent("set r 50")
    later.control.stop_mission()
    later.run(1.5)
    assert program.ask("set v 0.3") == [encode_float(0.3)]
    sent = [e.command for e in later.exchanges if not e.automatic]
    assert sent.index("set r 50") < sent.index("set v 0.3")
    assert later.control.teleop.board_settings["r"] == "50"


def test_the_operator_can_hold_the_program_still(later, program):
    later.port.hold("the operator stopped the robot")
    assert program.ask("set p 0.2") == ["Error: refused: the operator stopped the robot"]
    assert list(program.bulk()) == BULK_FIELDS
    later.port.hold(None)
    assert program.ask("set p 0.2") == [encode_float(0.2)]


def test_a_program_that_hangs_up_after_a_move_has_the_robot_stopped(later, program):
    program.ask("set p 0.25")
    later.run(0.3)
    sent = len(later.exchanges)
    program.close()
    give_up = time.monotonic() + REPLY_WAIT_S
    while not any(e.command == "get bulk_data" and not e.automatic
                  for e in later.exchanges[sent:]):  # fmt: skip
        assert time.monotonic() < give_up, "no stop after the program hung up"
        later.control.tick()
        time.sleep(0.005)
    stops = [e.command for e in later.exchanges[sent:] if e.command.startswith("set p")]
    assert stops and stops[0] != "set p 0.25"  # a braking target
    later.run(1.0)
    assert later.board.true_pose.x < 0.25


# -- replies within the board's timeout ---------------------------------------------------


def test_a_loop_that_does_not_answer_gives_an_error_and_sends_nothing_late():
    bench = Bench("later", link_timeout=0.1)
    program = Program(bench.port.path)  # nobody ticks the loop
    try:
        program.replies()
        started = time.monotonic()
        (line,) = program.ask("set p 0.2")
        assert line.startswith("Error: no answer from the control loop within 0.7 s")
        assert time.monotonic() - started < 2.0
        bench.run(0.5)
        assert not bench.sent("set p 0.2")  # given up on: not sent late
    finally:
        program.close()
        assert bench.port.close()


def test_a_lost_link_gives_an_error_line():
    bench = Bench("later")
    program = Program(bench.port.path, bench.control.tick)
    try:
        program.replies()
        bench.link.port.close()
        (line,) = program.ask("get bulk_data")
        assert line.startswith("Error: ")
        assert any(note.startswith("LINK LOST") for note in bench.notes)
    finally:
        program.close()
        assert bench.port.close()


def test_closing_joins_the_thread_and_the_program_sees_the_port_go(later, program):
    assert later.port.close(timeout=2.0)
    assert not later.port._thread.is_alive()
    assert select.select([program.fd], [], [], REPLY_WAIT_S)[0]
    try:
        gone = os.read(program.fd, 4096)
    except OSError:
        gone = b""  # EIO: the other end is closed
    assert gone == b""


# -- sharing a later board's increments ---------------------------------------------------


def test_odometry_of_the_daemon_and_the_program_both_stay_true_over_ten_metres(later, program):
    # The daemon polls at 20 Hz; the program reads every 0.3 s and adds imdl/imdr up, as
    # the ROS 2 driver does on a later board. Each read resets them on the board.
    assert later.control.autopoll
    start = len(later.exchanges)
    distance = 0.0
    later.driving = Intent.FORWARD
    while later.travelled() < 10.0:
        later.run(0.3)
        value = program.bulk()
        distance += (value["imdl"] + value["imdr"]) / 2
    later.driving = None
    later.run(2.0)
    value = program.bulk()
    distance += (value["imdl"] + value["imdr"]) / 2
    truth = later.travelled()
    program_error = abs(distance - truth)
    pose, real = later.control.odometry.pose, later.board.true_pose
    daemon_error = math.hypot(real.x - pose.x, real.y - pose.y)
    print(
        f"\n10 m run: truth {truth:.4f} m; program {distance:.4f} m (error "
        f"{program_error * 1e6:.2f} um); daemon error {daemon_error * 1e6:.2f} um"
    )
    assert truth > 10.0
    assert program_error <= 0.01
    assert daemon_error <= 0.01
    # Without the sharing the program would have had only what its own reads reset:
    # the board's raw answers to them, as the loop's exchanges show.
    own = [e for e in later.exchanges[start:] if e.command == "get bulk_data" and not e.automatic]
    raw = sum((e.value["imdl"] + e.value["imdr"]) / 2 for e in own)  # type: ignore[index]
    print(f"raw pass-through: {raw:.4f} m over {len(own)} reads")
    assert raw < 0.5 * truth


def exchange(lines: tuple[str, ...], automatic: bool = False) -> Exchange:
    value = parse_reply(lines).value
    return Exchange("get", "get bulk_data", lines, value, None, 0.0, 0.0, automatic)


def bulk_line(imdl: str, imdr: str) -> str:
    return (f"cang:F*00000000,cdis:F*00000000,gvr:F*00000000,tilt_angle_from_home:F*F051B83D,"
            f"imdl:{imdl},imdr:{imdr},cvg:F*00000000,mode:I*02000000,")  # fmt: skip


def test_the_program_s_read_carries_what_the_daemon_s_reads_took():
    shared = SharedReadings(lambda: True)
    for _ in range(3):  # the daemon's polls: 0.1 m and 0.2 m each
        shared.tap(exchange((bulk_line(encode_float(0.1), encode_float(0.2)),), automatic=True))
    with shared.own_read():  # the program's own read is not counted twice
        mine = exchange((bulk_line(encode_float(0.05), encode_float(0.05)),))
        shared.tap(mine)
    (line,) = shared.share(mine)
    value = parse_reply([line]).value
    assert isinstance(value, dict)
    assert value["imdl"] == pytest.approx(0.35) and value["imdr"] == pytest.approx(0.65)
    assert line.startswith("cang:F*00000000,") and line.endswith(",mode:I*02000000,")
    assert shared.pending == {"imdl": 0.0, "imdr": 0.0}  # its now


def test_without_sharing_the_daemon_s_polls_would_take_the_program_s_travel():
    # The failing case the sharing is for: the raw reply holds only the last 50 ms.
    shared = SharedReadings(lambda: True)
    for _ in range(5):
        shared.tap(exchange((bulk_line(encode_float(0.02), encode_float(0.02)),), True))
    raw = exchange((bulk_line(encode_float(0.0), encode_float(0.0)),))
    assert parse_reply(raw.lines).value["imdl"] == 0.0  # type: ignore[index]
    (shared_line,) = shared.share(raw)
    assert parse_reply([shared_line]).value["imdl"] == pytest.approx(0.1)  # type: ignore[index]


def test_totals_pass_through_unchanged():
    shared = SharedReadings(lambda: False)
    shared.tap(exchange((bulk_line(encode_float(1.0), encode_float(1.0)),), True))
    mine = exchange((bulk_line(encode_float(1.5), encode_float(1.5)),))
    assert shared.share(mine) == mine.lines


def test_the_reply_keeps_the_board_s_hex_case_and_untouched_fields():
    line = "imdl:F*CDCCCC3D,imdr:F*cdcccc3d,mode:I*02000000"
    added = add_to_list(line, {"imdl": 0.1, "imdr": 0.1})
    twice = encode_float(0.2)
    assert added == f"imdl:F*{twice[2:].upper()},imdr:{twice},mode:I*02000000"
    assert add_to_list(line, {"imdl": 0.0}) == line


def test_a_program_that_floods_the_port_is_answered_no_faster_than_a_board_s_line():
    """Each line is a job the loop wakes for, at real-time priority: a flood is taken at
    the pace of a board's line, not as fast as the program writes (review of issue 27)."""
    link = BoardLink.open("giraff-sim://?clock=virtual&firmware=later")
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(link.port.clock),
                          clock=link.port.clock)  # fmt: skip
    control.start(stepped=1.0)
    port = VirtualPort(RobotService(control, DriveSetup.on_loop(control, None)))
    port.start()
    lines = 100
    try:
        program = Program(port.path, lambda: time.sleep(0.001))
        assert program.replies()  # the greeting
        started = time.monotonic()
        os.write(program.fd, b"get v\r" * lines)
        for _ in range(lines):
            assert len(program.replies()) == 1
        took = time.monotonic() - started
        program.close()
    finally:
        assert port.close()
        assert control.stop()
    assert took >= (lines - 1) * MIN_LINE_S


def test_settings_that_let_the_program_only_read_refuse_its_moves():
    """`virtual_port = "reads"` (the settings file): it reads and sets, but never drives."""
    bench = Bench("later")
    bench.port.drives = False
    program = Program(bench.port.path, bench.control.tick)
    try:
        assert program.replies()  # the greeting
        assert program.ask("set v 0.3") == [encode_float(0.3)]
        assert program.ask("set p 0.2") == [f"Error: {READS_ONLY}"]
        assert not bench.sent("set p 0.2")
        assert list(program.bulk()) == BULK_FIELDS
        assert bench.service.controls().holder is None
    finally:
        program.close()
        assert bench.port.close()
        bench.link.close()


def test_the_operator_hands_the_controls_to_the_program_and_takes_them_back(later, program):
    """§4.5 and issue 27: the program drives when the operator hands it the controls."""
    later.service.attach("console", take=True)
    assert program.ask("set v 0.3") == [encode_float(0.3)]  # a setting: nobody else drives
    refused = program.ask("set p 0.2")
    assert refused == ["Error: refused: console holds the controls (a console's Ctrl+T or "
                       "`take` asks for them)"]  # fmt: skip
    assert later.service.execute(c.HandControls(), "console").ok
    assert later.service.controls().holder == PROGRAM
    assert program.ask("set p 0.2") == [encode_float(0.2)]
    later.run(0.3)
    assert later.service.execute(c.TakeControls(), "console").ok
    later.run(1.5)
    assert later.board.true_pose.x < 0.12  # its move stopped when the controls were taken
    assert program.ask("set p 0.2")[0].startswith("Error: refused: console holds the controls")


def test_the_controls_are_handed_only_to_a_program_that_is_there(later):
    later.service.attach("console", take=True)
    reply = later.service.execute(c.HandControls(), "console")
    assert not reply.ok and "nobody has the virtual port open" in reply.text
    assert later.service.controls().holder == "console"


def test_the_mode_a_driver_set_once_goes_back_to_the_board_before_its_next_command(later, program):
    """One driver sets mode 2 at start-up only (wire-facts); a mission or the keys set
    mode 0 meanwhile: its vg must not be read as a gear ratio (review of issue 27)."""
    assert program.ask("set mode 2") == ["I*02000000"]
    program.ask("set a 0.4")
    later.control.teleop.board_set("mode", "0")  # as a mission's commands leave it
    assert program.ask("set vg 10") == [encode_float(10.0)]  # degrees per second, kept
    assert later.control.teleop.board_settings["mode"] == "2"
    assert later.sent("set mode 2")


def test_a_negative_speed_is_refused_not_clamped_into_another_kind_of_move(later, program):
    program.ask("set mode 2")
    assert program.ask("set v -0.3")[0].startswith("Error: refused: v must be")
    assert not later.sent("set v 0") or later.control.teleop.board_settings.get("v") != "0"


def test_a_program_that_goes_quiet_gives_the_controls_back(later, program, monkeypatch):
    monkeypatch.setattr(virtual_port, "QUIET_S", 0.2)
    program.ask("set v 0.3")
    assert program.ask("set p 0.1") == [encode_float(0.1)]
    assert later.service.controls().holder == PROGRAM
    give_up = time.monotonic() + REPLY_WAIT_S
    while later.service.controls().holder is not None:
        assert time.monotonic() < give_up, "the quiet program kept the controls"
        later.step()
        time.sleep(0.01)
