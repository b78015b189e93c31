"""`giraff-console send`: the console's guard on the shell's path to the board.

The robot's movement is measured with the simulator's true pose, which the wire never
shows: in-process on a virtual clock, and through `sim --pose-log` in another process.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from giraff_console.cli import main
from giraff_console.cli.send import UNSAFE_WARNING, read_settings, send_commands
from giraff_console.link import BoardLink
from giraff_console.protocol import parse_command
from giraff_console.robot.teleop import DriveLimits
from tests.conftest import start_sim_process, stop_sim_process

# The issue's attack: 5 m at 0.6 m/s, after `send` has exited.
ATTACK = ("set r 1000", "set mode 0", "set v 0.6", "set a 0.1", "set vg 0", "set p 5")
# Settings within the limits, and a move within the reach.
SAFE_MOVE = ("set r 1000", "set mode 0", "set v 0.3", "set a 0.5", "set vg 0", "set p 0.2")
LIMITS = DriveLimits()


class Board:
    """The in-process simulator on a virtual clock, reached through a link."""

    def __init__(self) -> None:
        self.port = serial.serial_for_url("giraff-sim://?clock=virtual")
        self.link = BoardLink(self.port, timeout=1.0)
        self.link.handshake(power_line="none")
        self.sent: list[str] = []
        self.link.add_observer(lambda exchange: self.sent.append(exchange.command))

    def send(self, *texts: str, unsafe: bool = False) -> int:
        return send_commands(self.link, [parse_command(t) for t in texts], LIMITS, unsafe=unsafe)

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


def test_the_issue_s_attack_is_refused_and_the_robot_does_not_move(board, capsys):
    before = board.port.board.true_pose
    assert board.send(*ATTACK) == 1
    assert "refused: set v 0.6" in capsys.readouterr().err
    assert not any(c.startswith("set") for c in board.sent)  # only the settings read
    board.port.clock.advance(20)
    assert board.port.board.true_pose == before


def test_unsafe_lets_the_attack_through(board):
    # The same commands without the guard: the robot drives off, so the guard is what
    # stopped it above.
    assert board.send(*ATTACK, unsafe=True) == 0
    assert board.travel_after(20) > 4.9


def test_an_accepted_move_stays_within_the_runaway_limit(board, capsys):
    assert board.send(*SAFE_MOVE) == 0, capsys.readouterr().err
    assert 0.19 < board.travel_after(20) <= LIMITS.runaway


def test_a_move_is_checked_against_what_the_board_really_holds(board, capsys):
    # The board was left at v 0.6 by someone else: a move on it is refused.
    board.link.set("v", 0.6)
    assert board.send("set r 1000", "set mode 0", "set a 0.5", "set vg 0", "set p 0.2") == 1
    assert "v must be in" in capsys.readouterr().err
    # At v 0.4, read back as the float32 0.4000000059, the same move goes.
    board.link.set("v", 0.4)
    assert board.send("set r 1000", "set mode 0", "set a 0.5", "set vg 0", "set p 0.2") == 0


def test_settings_read_back_are_the_values_that_were_sent(board):
    board.link.set("v", 0.4)
    board.link.set("a", 0.37)
    board.link.set("r", 1000)
    # vg is still at the board's power-up 1 (B.2).
    assert read_settings(board.link) == {"r": "1000", "v": "0.4", "a": "0.37", "vg": "1"}


def test_a_move_needs_the_mode_set_in_the_same_call(board, capsys):
    # The board's writable mode bits cannot be read back (A.4.8).
    assert board.send("set r 1000", "set v 0.3", "set a 0.5", "set vg 0", "set p 0.2") == 1
    assert "mode is unknown" in capsys.readouterr().err


def test_nothing_is_sent_when_a_later_command_is_refused(board, capsys):
    assert board.send("set v 0.3", "home", "reset") == 1
    assert "refused: reset" in capsys.readouterr().err
    assert board.sent == ["get r", "get v", "get a", "get vg"]


def test_nothing_is_sent_after_a_board_error(board):
    assert board.send("get nonsense", "set p 5", unsafe=True) == 1
    assert board.sent == ["get nonsense"]


def run_send(*args: str) -> int:
    return main(["send", *args])


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
    assert "ON BLOCKS" in capsys.readouterr().out


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
        assert attack.returncode == 1
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
