"""The daemon serves its clients within bounds, and the operator's stop always wins
(issue 30): the real `giraff-console serve` in a child process, on the built-in
simulator, and real sockets to it from here (tests/service/daemon_rig.py)."""

from __future__ import annotations

import contextlib
import json
import os
import resource
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from giraff_console.robot.loop_events import MissionChanged
from giraff_console.service import commands as c
from giraff_console.service import wire
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.daemon import Answered, Welcome, descriptors_for
from giraff_console.service.remote import DaemonGone, RemoteRobot
from tests.service.daemon_rig import (
    DaemonProcess,
    Heard,
    program,
    run_cli,
    start_daemon,
    stop_daemon,
)

SIM = ("--sim", "--no-landmarks")
# Seconds for an answer, on a loaded 2-core machine.
WAIT_S = 5.0


@pytest.fixture
def runtime(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A runtime folder of the test's own, short enough for a socket's path, and an
    empty settings folder (as tests/service/test_daemon.py's)."""
    folder = Path(tempfile.mkdtemp(prefix="gb-", dir="/tmp"))
    (folder / "config").mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(folder / "config"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def serve(runtime: Path) -> Iterator[Callable[..., DaemonProcess]]:
    started: list[DaemonProcess] = []

    def start(*args: str, files: int | None = None) -> DaemonProcess:
        daemon = start_daemon(runtime, args, f"serve-{len(started)}.log", files=files)
        started.append(daemon)
        return daemon

    yield start
    for daemon in started:
        stop_daemon(daemon)


@pytest.fixture
def closing() -> Iterator[list[RemoteRobot | socket.socket]]:
    """Whatever a test connects is closed afterwards."""
    opened: list[RemoteRobot | socket.socket] = []
    yield opened
    for each in opened:
        with contextlib.suppress(OSError):
            each.close()


class Raw:
    """A bare connection: any bytes out, the daemon's messages in."""

    def __init__(self, path: Path) -> None:
        self.socket = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.socket.connect(str(path))  # blocking: waits while the backlog is full
        self.socket.settimeout(WAIT_S)
        self._buffer = b""

    def send(self, message: object) -> None:
        self.socket.sendall(json.dumps(wire.encode(message)).encode() + b"\n")

    def until(self, found: Callable[[object], bool]) -> object:
        """The daemon's messages until one that is `found`; fails after WAIT_S."""
        deadline = time.monotonic() + WAIT_S
        while True:
            while b"\n" in self._buffer:
                line, self._buffer = self._buffer.split(b"\n", 1)
                message = wire.decode(json.loads(line))
                if found(message):
                    return message
            assert time.monotonic() < deadline, "nothing like it came"
            chunk = self.socket.recv(65536)
            assert chunk, "the daemon hung up"
            self._buffer += chunk

    def answer(self, number: int) -> Answered:
        found = self.until(lambda m: isinstance(m, Answered) and m.number == number)
        assert isinstance(found, Answered)
        return found


def console(daemon: DaemonProcess, opened: list, name: str, take: bool = False) -> RemoteRobot:
    robot = RemoteRobot(daemon.socket, name, take=take)
    opened.append(robot)
    return robot


def test_a_console_over_the_limit_is_refused_and_the_others_are_still_served(serve, closing):
    daemon = serve(*SIM, "--max-consoles", "2")
    first, second = (console(daemon, closing, name) for name in ("first", "second"))
    # A console over the limit is told so as it attaches, not welcomed and then dropped.
    with pytest.raises(DaemonGone, match=r"has as many consoles attached as it takes \(2\); "
                       "`giraff-console stop` still stops the robot"):  # fmt: skip
        console(daemon, closing, "third")
    # Anything but a stop asked over the limit is refused, and the connection closed.
    raw = Raw(daemon.socket)
    closing.append(raw.socket)
    raw.send(Hello("raw", take=False))
    welcome = raw.until(lambda m: isinstance(m, Welcome))
    assert isinstance(welcome, Welcome) and welcome.over_limit == 2
    raw.send(Asked(3, c.Status()))
    refused = raw.answer(3).reply
    assert not refused.ok and "too many consoles attached (limit 2)" in refused.text, refused
    assert all(robot.execute(c.Status(), timeout=WAIT_S).ok for robot in (first, second))
    assert "third" not in " ".join(first.execute(c.Status(), timeout=WAIT_S).lines)
    # One leaves: the next is attached.
    first.close()
    deadline = time.monotonic() + WAIT_S
    while True:
        with contextlib.suppress(DaemonGone):
            fourth = console(daemon, closing, "fourth")
            if fourth.execute(c.Status(), timeout=WAIT_S).ok:
                break
        assert time.monotonic() < deadline, "no console attached after one left"
        time.sleep(0.1)
    assert daemon.alive(), daemon.notes()


def test_a_stop_command_gets_through_with_the_limit_full_and_connections_waiting(serve, closing):
    daemon = serve(*SIM, "--max-consoles", "2", "--sim-speed", "4")
    driver = console(daemon, closing, "driver", take=True)
    other = console(daemon, closing, "other")
    heard = Heard()
    other.subscribe(heard)
    assert driver.execute(c.Go("kitchen"), timeout=WAIT_S).ok
    heard.wait_for(MissionChanged, lambda e: e.running, WAIT_S, what="the mission started")
    # More connections than may wait to say Hello, saying nothing.
    for _ in range(40):
        closing.append(Raw(daemon.socket).socket)
    stopped = run_cli("stop", timeout=30.0)
    assert stopped.returncode == 0, stopped.stderr
    ended = heard.wait_for(MissionChanged, lambda e: not e.running, WAIT_S,
                           what="the mission ended by the stop")  # fmt: skip
    assert ended.end is not None and "stop" in ended.end.words, ended
    assert daemon.alive(), daemon.notes()


def test_an_oversized_line_is_refused_unread_and_the_connection_goes_on(serve, closing):
    daemon = serve(*SIM)
    raw = Raw(daemon.socket)
    closing.append(raw.socket)
    raw.send(Hello("raw", take=False))
    raw.until(lambda m: isinstance(m, Welcome))
    # Valid JSON, far over a request's length, sent in pieces.
    raw.socket.sendall(b'{"type":"Asked","number":3,"request":"' + b"x" * 300_000 + b'"}\n')
    refused = raw.answer(-1)
    assert not refused.reply.ok and "a line over 65536 bytes" in refused.reply.text
    raw.send(Asked(7, c.Status()))
    assert raw.answer(7).reply.ok
    assert daemon.alive(), daemon.notes()


def test_many_idle_consoles_do_not_make_threads(serve, closing):
    daemon = serve(*SIM, "--max-consoles", "250")
    threads_before = len(list(Path(f"/proc/{daemon.pid}/task").iterdir()))
    raws = []
    for n in range(200):
        raw = Raw(daemon.socket)
        closing.append(raw.socket)
        raw.send(Hello(f"idle {n}", take=False))
        raws.append(raw)
    raws[-1].until(lambda m: isinstance(m, Welcome))
    threads_after = len(list(Path(f"/proc/{daemon.pid}/task").iterdir()))
    assert threads_after <= threads_before + 1, (threads_before, threads_after)
    raws[-1].send(Asked(5, c.Status()))
    status = raws[-1].answer(5)
    assert status.reply.ok and "idle 0" in " ".join(status.reply.lines)


def test_a_console_limit_the_file_descriptors_cannot_hold_is_refused_at_start(tmp_path):
    """Every connection is a descriptor: a daemon out of them can only refuse the newest,
    a `stop` perhaps. So `serve` refuses a limit its descriptors cannot hold, and says
    what it would need (here 40 files for 100 consoles)."""

    def forty_files() -> None:  # in the child, before it runs the program
        resource.setrlimit(resource.RLIMIT_NOFILE, (40, 40))

    ended = subprocess.run(
        program("serve", *SIM, "--max-consoles", "100"), stdin=subprocess.DEVNULL,
        capture_output=True, text=True, timeout=60, preexec_fn=forty_files,
        env=os.environ | {"XDG_RUNTIME_DIR": str(tmp_path)},
    )  # fmt: skip
    assert ended.returncode == 2, ended.stderr
    assert (f"max_consoles 100 needs up to {descriptors_for(100)} file descriptors, and "
            "this process may open 40 (ulimit -n)") in ended.stderr  # fmt: skip
    assert "Traceback" not in ended.stderr


def test_a_request_that_raises_inside_is_refused_without_its_text(serve, closing):
    daemon = serve(*SIM)
    raw = Raw(daemon.socket)
    closing.append(raw.socket)
    raw.send(Hello("raw", take=False))
    raw.until(lambda m: isinstance(m, Welcome))
    # A list where a room's name belongs.
    asked = wire.encode(Asked(4, c.Go("kitchen")))
    assert isinstance(asked, dict) and isinstance(asked["request"], dict)
    asked["request"]["room"] = ["kitchen"]
    raw.socket.sendall(json.dumps(asked).encode() + b"\n")
    refused = raw.until(lambda m: isinstance(m, Answered) and m.number in (4, -1))
    assert isinstance(refused, Answered) and not refused.reply.ok
    for python in ("Error", "Traceback", "unhashable", "'list'"):
        assert python not in refused.reply.text, refused.reply.text
    raw.send(Asked(5, c.Status()))
    assert raw.answer(5).reply.ok
