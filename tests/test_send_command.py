"""`giraff-console send`: the console's guard on the shell's path to the board, through
the robot service: the robot's in this process without a daemon, the daemon's beside
one (the same request, c.SendCommands; tests/service/test_send_commands.py has the
service's side).

The robot's movement is measured with the simulator's true pose, which the wire never
shows: through `sim --pose-log` in another process, and through a console attached to
the daemon (its snapshots' pose, and the exchanges it hears).
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import serial

from giraff_console.cli.main import main
from giraff_console.cli.send import UNSAFE_WARNING, print_sent, send_unchecked
from giraff_console.link import BoardLink, Exchange
from giraff_console.protocol import parse_command
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.remote import RemoteRobot
from tests.conftest import start_sim_process, stop_sim_process
from tests.service.daemon_rig import (
    DaemonProcess,
    Heard,
    at_rest,
    distance,
    run_cli,
    start_daemon,
    stop_daemon,
)

# The attack: 5 m at 0.6 m/s, after `send` has exited.
ATTACK = ("set r 1000", "set mode 0", "set v 0.6", "set a 0.1", "set vg 0", "set p 5")
# A daemon on the built-in simulator, without the camera's CPU (tests/service/test_daemon.py).
SIM = ("--sim", "--no-landmarks")
WAIT_S = 5.0


def run_send(*args: str) -> int:
    return main(["send", *args])


# -- without a daemon: the robot in this process ---------------------------------------


@pytest.mark.parametrize(
    ("command", "why"),
    [
        ("set P 5", "p beyond"),
        ("reset", "only bare command is home"),
        ("set vgr 5", "vgr must be"),
        ("set cdp 1", "cdp must be"),
        ("set r 100000", "r must be"),
        ("set r -1", "r must be"),
        ("set undock -0.3", "undock is refused"),
        ("get " + "x" * 100_000, "longer than the board's line"),
    ],
)
def test_send_refuses_what_the_command_line_refuses(command, why, capsys):
    assert run_send("set r 1000", "set mode 0", "set v 0.3", "set a 0.5", "set vg 0",
                    command) == 1  # fmt: skip
    out, err = capsys.readouterr()
    assert why in err
    assert out == ""  # nothing was sent, so nothing was answered
    assert "Traceback" not in err


def test_the_attack_is_refused_and_nothing_of_it_is_sent(capsys):
    assert run_send(*ATTACK) == 1
    out, err = capsys.readouterr()
    assert "refused: set v 0.6" in err and "nothing was sent" in err
    assert out == ""


def test_an_accepted_move_is_answered_and_ended_before_send_exits(capsys):
    started = time.monotonic()
    assert run_send("set r 1000", "set mode 0", "set v 0.4", "set a 0.5", "set vg 0",
                    "set p 0.2", "get bulk_data") == 0  # fmt: skip
    out, err = capsys.readouterr()
    assert "128 (MOVING)" in out
    # The robot is stopped as the process ends, so `send` waited for the move's end.
    assert "the robot moves; send ends once it stops" in err
    assert "still moves" not in err
    assert time.monotonic() - started > 0.5


def test_too_many_commands_at_once_are_refused_before_anything_is_sent(capsys):
    assert run_send(*["get v"] * (c.MAX_COMMANDS + 1)) == 1
    out, err = capsys.readouterr()
    assert f"at most {c.MAX_COMMANDS} commands" in err and out == ""


def test_a_line_longer_than_the_board_s_is_refused_even_when_unsafe(capsys):
    assert run_send("--unsafe", "get " + "x" * 100_000) == 1
    out, err = capsys.readouterr()
    assert "longer than the board's line" in err
    assert out == ""


def test_unsafe_warns_loudly_and_sends(capsys):
    assert run_send("--unsafe", "set v 0.6", "get v") == 0
    out, err = capsys.readouterr()
    assert UNSAFE_WARNING in err
    assert out.splitlines() == ["> set v 0.6", "  0.60000", "> get v", "  0.60000"]


def test_unsafe_is_explained_in_the_help(capsys):
    with pytest.raises(SystemExit):
        run_send("--help")
    help_text = capsys.readouterr().out
    assert "ON BLOCKS" in help_text
    assert "daemon" in help_text


def test_firmware_with_a_port_is_a_mistake_in_the_options(capsys):
    assert run_send("--port", "giraff-sim://", "--firmware", "later", "get v") == 2
    assert "--firmware" in capsys.readouterr().err


class Board:
    """The in-process simulator on a virtual clock, reached through a link of its own:
    what `--unsafe` does."""

    def __init__(self) -> None:
        self.port = serial.serial_for_url("giraff-sim://?clock=virtual")
        self.link = BoardLink(self.port, timeout=1.0)
        self.link.handshake(power_line="none")
        self.sent: list[str] = []
        self.link.add_observer(lambda exchange: self.sent.append(exchange.command))

    def send_unsafe(self, *texts: str) -> int:
        commands = [parse_command(t) for t in texts]
        return print_sent(send_unchecked(self.link, commands), len(commands))

    def travel_after(self, seconds: float) -> float:
        """How far the robot really goes in the next `seconds`, with no one at the wheel."""
        start = self.port.board.true_pose
        self.port.clock.advance(seconds)
        end = self.port.board.true_pose
        return math.hypot(end.x - start.x, end.y - start.y)


@pytest.fixture
def board() -> Iterator[Board]:
    bench = Board()
    yield bench
    bench.link.close()


def test_unsafe_lets_the_attack_through(board):
    # The same commands without the guard: the robot drives off, so the guard is what
    # stops it everywhere else.
    assert board.send_unsafe(*ATTACK) == 0
    assert board.travel_after(20) > 4.9


def test_unsafe_sends_nothing_after_a_board_error(board, capsys):
    assert board.send_unsafe("get nonsense", "set p 5") == 1
    assert board.sent == ["get nonsense"]
    out, err = capsys.readouterr()
    assert out.splitlines() == ["> get nonsense", "  board error: Unknown name: nonsense"]
    assert "nothing after it was sent" in err


def _pose_log(path: Path) -> list[list[float]]:
    return [[float(field) for field in line.split()] for line in path.read_text().splitlines()
            if len(line.split()) == 5]  # fmt: skip


def _log_after(path: Path, seconds: float, timeout: float = 10.0) -> list[list[float]]:
    """The pose log once it covers `seconds` more of the simulator's time."""
    first = _pose_log(path)
    deadline = time.monotonic() + timeout
    while True:
        rows = _pose_log(path)
        if first and rows and rows[-1][0] - first[-1][0] >= seconds:
            return rows
        assert time.monotonic() < deadline, "the pose log stopped"
        time.sleep(0.02)


def test_send_to_a_simulator_in_another_process(tmp_path):
    log = tmp_path / "pose.log"
    process, path = start_sim_process("--pose-log", str(log))
    try:
        attack = subprocess.run(
            [sys.executable, "-m", "giraff_console", "send", "--port", path, *ATTACK],
            capture_output=True, text=True, timeout=30,
        )  # fmt: skip
        assert attack.returncode == 1, attack.stderr
        assert "refused: set v 0.6" in attack.stderr
        rows = _log_after(log, 0.5)
        assert all(row[1:] == rows[0][1:] for row in rows)  # never moved, never MOVING
        unsafe = subprocess.run(
            [sys.executable, "-m", "giraff_console", "send", "--unsafe", "--port", path, *ATTACK],
            capture_output=True, text=True, timeout=30,
        )  # fmt: skip
        assert unsafe.returncode == 0, unsafe.stderr
        assert UNSAFE_WARNING in unsafe.stderr
        rows = _log_after(log, 0.3)
        assert rows[-1][4] == 1 and rows[-1][1] > rows[0][1]  # off it goes
    finally:
        assert stop_sim_process(process) == 0


# -- beside a daemon: the daemon's robot ------------------------------------------------


@pytest.fixture
def serve(monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[..., DaemonProcess]]:
    """Starts `giraff-console serve ARGS` in a runtime folder of the test's own (and no
    settings file of the machine's); every daemon started is ended afterwards."""
    folder = Path(tempfile.mkdtemp(prefix="gs-", dir="/tmp"))
    (folder / "config").mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(folder / "config"))
    started: list[DaemonProcess] = []

    def start(*args: str) -> DaemonProcess:
        daemon = start_daemon(folder, args, log_name=f"serve-{len(started)}.log")
        started.append(daemon)
        return daemon

    yield start
    for daemon in started:
        stop_daemon(daemon)
    shutil.rmtree(folder, ignore_errors=True)


def watching(daemon: DaemonProcess) -> tuple[RemoteRobot, Heard]:
    """A console that watches the daemon's robot without the controls."""
    watcher = RemoteRobot(daemon.socket, "watcher", take=False)
    heard = Heard()
    watcher.subscribe(heard)
    return watcher, heard


SETS_AND_GETS = ("get v", "set v 0.3", "get v", "get bulk_data")


def test_send_prints_the_same_with_and_without_a_daemon(serve):
    alone = run_cli("send", *SETS_AND_GETS)
    assert alone.returncode == 0, alone.stderr
    daemon = serve(*SIM)
    asked = run_cli("send", *SETS_AND_GETS)
    assert asked.returncode == 0, f"{asked.stderr}\n{daemon.notes()}"
    assert f"asking the daemon at {daemon.socket}" in asked.stderr
    # Both robots' loops set the board up alike as they connected (v: teleop's speed).
    assert asked.stdout == alone.stdout
    assert asked.stdout.splitlines()[:4] == ["> get v", "  0.40000", "> set v 0.3", "  0.30000"]
    # The board line, as on its own, from the daemon's snapshot.
    assert "the thesis's firmware" in asked.stderr


def test_the_attack_beside_the_daemon_is_refused_and_the_robot_stays(serve):
    daemon = serve(*SIM)
    watcher, heard = watching(daemon)
    try:
        rest = heard.wait_for(Telemetry, at_rest, WAIT_S, what="the robot at rest")
        mark = heard.mark()
        result = run_cli("send", *ATTACK)
        assert result.returncode == 1, result.stderr
        assert "refused: set v 0.6" in result.stderr and result.stdout == ""
        time.sleep(0.5)
        typed = [e.command for e in heard.since(mark, Exchange) if not e.automatic]
        assert typed == [], typed
        last = heard.latest(Telemetry)
        assert last is not None and distance(rest.pose, last.pose) < 0.005
    finally:
        watcher.close()


def test_a_get_goes_beside_the_daemon_s_mission_and_a_set_is_refused(serve):
    daemon = serve(*SIM, "--sim-speed", "0.5")
    watcher, heard = watching(daemon)
    try:
        # A console starts a go and leaves: the mission carries on, the controls free.
        driver = RemoteRobot(daemon.socket, "driver", take=True)
        assert driver.execute(c.Go("room-101"), timeout=WAIT_S).ok
        driver.close()
        heard.wait_for(MissionChanged, lambda e: e.running, WAIT_S, what="the go started")
        read = run_cli("send", "get bulk_data", "get v")
        assert read.returncode == 0, f"{read.stderr}\n{daemon.notes()}"
        assert read.stdout.splitlines()[0] == "> get bulk_data"
        # A set would take the free controls, but not the board from under the mission.
        meddling = run_cli("send", "set v 0.1")
        assert meddling.returncode == 1
        assert "not while go room-101 runs" in meddling.stderr
        # The mission went on through both, and nothing ended it.
        changes = heard.since(0, MissionChanged)
        assert [change.running for change in changes] == [True], changes
        typed = [e.command for e in heard.since(0, Exchange) if not e.automatic]
        assert "get bulk_data" in typed and "set v 0.1" not in typed
    finally:
        watcher.close()


def test_a_set_beside_the_daemon_needs_the_controls(serve):
    daemon = serve(*SIM)
    holder = RemoteRobot(daemon.socket, "holder", take=True)
    try:
        refused = run_cli("send", "set v 0.3")
        assert refused.returncode == 1
        assert "holder" in refused.stderr and "holds the controls" in refused.stderr
        assert run_cli("send", "get v").returncode == 0
    finally:
        holder.close()


def test_unsafe_and_a_port_of_its_own_are_refused_beside_the_daemon(serve):
    serve(*SIM)
    unsafe = run_cli("send", "--unsafe", "get v")
    assert unsafe.returncode == 2
    assert "stop the daemon first" in unsafe.stderr and UNSAFE_WARNING not in unsafe.stderr
    port = run_cli("send", "--port", "giraff-sim://", "get v")
    assert port.returncode == 2 and "has the robot" in port.stderr
