"""Shared fixtures: a simulated board on a virtual clock, and the simulator in a subprocess."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.protocol import parse_reply
from giraff_console.sim import BoardConfig, GiraffBoard


class SimBench:
    """A board on a virtual clock, driven through its command interpreter."""

    def __init__(self, config: BoardConfig | None = None) -> None:
        self.clock = VirtualClock()
        self.board = GiraffBoard(self.clock, config)

    def cmd(self, line: str) -> str:
        """Run a command; return the raw reply line ("" for none). Checks the prompt."""
        reply = self.board.execute(line).decode("ascii")
        assert reply.endswith("OK >\r\n"), reply
        return reply[: -len("OK >\r\n")].rstrip("\r\n")

    def value(self, line: str):
        return parse_reply([self.cmd(line)]).value

    def bulk(self) -> dict:
        return self.value("get bulk_data")

    def run(self, *commands: str) -> None:
        for command in commands:
            reply = self.cmd(command)
            assert "rror" not in reply and "Unknown" not in reply, (command, reply)

    def advance(self, seconds: float) -> None:
        self.clock.advance(seconds)

    def run_until_stopped(self, step: float = 0.05, limit: float = 120.0) -> float:
        """Advance until MOVING clears; returns the time taken."""
        start = self.clock.now()
        while self.bulk()["mode"] & 128:
            assert self.clock.now() - start < limit, "the move never finished"
            self.advance(step)
        return self.clock.now() - start


@pytest.fixture
def sim() -> SimBench:
    return SimBench()


def start_sim_process(*args: str) -> tuple[subprocess.Popen, str]:
    """`giraff-console sim --pty ARGS` in a subprocess; returns it and its device path."""
    process = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    path = process.stdout.readline().strip()
    assert path.startswith("/dev/"), f"first line was {path!r}"
    return process, path


def stop_sim_process(process: subprocess.Popen, sig: int = signal.SIGTERM) -> int:
    if process.poll() is None:
        process.send_signal(sig)
    try:
        return process.wait(timeout=5)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        raise


@pytest.fixture
def sim_pty() -> Iterator[str]:
    """The simulator serving on a pty in another process; yields the device path."""
    process, path = start_sim_process()
    try:
        yield path
    finally:
        assert stop_sim_process(process) == 0


@pytest.fixture
def pty_pair() -> Iterator[tuple[int, str]]:
    """A bare pseudo-terminal: the test plays the board on the master fd."""
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    try:
        yield master, path
    finally:
        os.close(slave)
        os.close(master)
