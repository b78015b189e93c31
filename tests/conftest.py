"""Shared fixtures: a simulated board on a virtual clock, and the simulator in a subprocess."""

from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.protocol import parse_reply
from giraff_console.sim import BoardConfig, GiraffBoard


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C as at a terminal. A shell without job control starts an asynchronous
    command (`sh -c 'pytest &'`) with SIGINT ignored, and every process a test
    starts inherits that: Python then installs no handler of its own, and the tests that
    Ctrl-C a client (`stop`, `watch`) wait out their timeouts. An operator presses Ctrl-C
    at a foreground job, which has the default."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True, scope="session")
def private_runtime_folder() -> Iterator[Path]:
    """A runtime folder of the tests' own: no console or command under test attaches to
    a daemon the machine runs, and a daemon a test starts is found by the others it
    starts (service/runtime_folder.py). Short, for a Unix socket's path."""
    folder = Path(tempfile.mkdtemp(prefix="xdg-", dir="/tmp"))
    before = os.environ.get("XDG_RUNTIME_DIR")
    os.environ["XDG_RUNTIME_DIR"] = str(folder)
    yield folder
    if before is None:
        del os.environ["XDG_RUNTIME_DIR"]
    else:
        os.environ["XDG_RUNTIME_DIR"] = before
    shutil.rmtree(folder, ignore_errors=True)


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


# How long a child process may take to start or to stop, on a loaded 2-core machine.
CHILD_TIMEOUT = 20.0


def start_sim_process(*args: str) -> tuple[subprocess.Popen, str]:
    """`giraff-console sim --pty ARGS` in a subprocess; returns it and its device path."""
    process = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        path = _first_line(process, CHILD_TIMEOUT)
        assert path.startswith("/dev/"), f"first line was {path!r}"
    except BaseException:
        kill_process(process)
        raise
    return process, path


def _first_line(process: subprocess.Popen, timeout: float) -> str:
    """The child's first line of output; fails, rather than waits for ever, if none comes."""
    assert process.stdout is not None
    fd = process.stdout.fileno()
    deadline = time.monotonic() + timeout
    output = b""
    while b"\n" not in output:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"no line from the simulator in {timeout:.0f} s: {output!r}"
        if select.select([fd], [], [], remaining)[0]:
            chunk = os.read(fd, 4096)
            assert chunk, f"the simulator ended before its first line: {output!r}"
            output += chunk
    return output.decode().split("\n", 1)[0].strip()


def stop_sim_process(process: subprocess.Popen, sig: int = signal.SIGTERM) -> int:
    """Send `sig` and reap; a child that outlives it is killed, and the test fails."""
    if process.poll() is None:
        process.send_signal(sig)
    try:
        return process.wait(timeout=CHILD_TIMEOUT)
    except subprocess.TimeoutExpired:
        kill_process(process)
        raise


def kill_process(process: subprocess.Popen) -> None:
    """SIGKILL and reap, so that no test leaves a child holding a pty."""
    process.kill()
    process.wait(timeout=CHILD_TIMEOUT)


@pytest.fixture
def sim_pty() -> Iterator[str]:
    """The simulator serving on a pty in another process; yields the device path."""
    process, path = start_sim_process()
    try:
        yield path
    finally:
        assert stop_sim_process(process) == 0


@pytest.fixture(scope="session")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The package as `pip install .` builds it, from the files a clean checkout has:
    not the editable install, whose egg-info in the tree would hide a data file missing
    from the package data. Built once for every test that needs it."""
    root = Path(__file__).resolve().parent.parent
    tmp = tmp_path_factory.mktemp("wheel")
    source = tmp / "source"
    for path in [root / "pyproject.toml", root / "README.md", *root.glob("giraff_console/**/*")]:
        if path.is_file() and "__pycache__" not in path.parts:
            target = source / path.relative_to(root)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(path, target)
    result = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp), str(source)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    (built,) = tmp.glob("giraff_console-*.whl")
    return built


@pytest.fixture(autouse=True)
def operator_data(tmp_path_factory: pytest.TempPathFactory,
                  monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """Sessions and routes that a test (or a console it starts) makes go to a folder of
    the test's own, never to the tester's ~/.local/share (data_folders.py)."""
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path_factory.mktemp("data")))


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
