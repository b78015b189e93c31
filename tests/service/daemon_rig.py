"""A `giraff-console serve` daemon in a subprocess, and what its consoles hear.

Shared by the daemon's tests (test_daemon.py): the real program in a child process on
the built-in simulator, in a runtime folder of the test's own; consoles attach to it
from the test's process, and the CLI runs in children of its own.
"""

from __future__ import annotations

import itertools
import math
import os
import resource
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service.events import ServiceEvent

# Seconds a child may take to start or to stop on a loaded 2-core machine.
START_TIMEOUT_S = 20.0
STOP_TIMEOUT_S = 10.0
# Seconds a CLI command may take; a mission at --sim-speed 8 takes a few.
CLI_TIMEOUT_S = 40.0
# What the daemon says on standard error once it takes consoles (serve_command.py).
SERVING = "giraff-console: serving the robot at"

Event = TypeVar("Event")


@dataclass
class DaemonProcess:
    """A `giraff-console serve` child: its process, its socket and its notes."""

    process: subprocess.Popen[bytes]
    socket: Path
    log: Path

    @property
    def pid(self) -> int:
        return self.process.pid

    def notes(self) -> str:
        """What it said on standard error so far: for assertion messages."""
        try:
            return self.log.read_text(errors="replace")
        except OSError as error:
            return f"(no log: {error})"

    def alive(self) -> bool:
        return self.process.poll() is None


def program(*args: str) -> list[str]:
    """`giraff-console ARGS`, as the installed command runs it."""
    return [sys.executable, "-m", "giraff_console", *args]


def start_daemon(runtime: Path, args: Sequence[str], log_name: str = "serve.log",
                 files: int | None = None) -> DaemonProcess:  # fmt: skip
    """`giraff-console serve ARGS` with XDG_RUNTIME_DIR at `runtime` (the environment
    must already say so, for the test's own consoles to find it), once it takes
    consoles; `files`, the most file descriptors it may hold (RLIMIT_NOFILE). Killed,
    and the test failed, if it does not take consoles within START_TIMEOUT_S."""
    log = runtime / log_name

    def limit_files() -> None:  # in the child, before it runs the program
        if files is not None:
            resource.setrlimit(resource.RLIMIT_NOFILE, (files, files))

    with open(log, "wb") as errors:
        process = subprocess.Popen(
            program("serve", *args),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=errors,
            env=dict(os.environ),
            preexec_fn=limit_files,
        )
    daemon = DaemonProcess(process, runtime / "giraff-console" / "robot.sock", log)
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not (SERVING in daemon.notes() and daemon.socket.exists()):
            assert daemon.alive(), (
                f"the daemon ended ({process.returncode}) before serving:\n{daemon.notes()}"
            )
            assert time.monotonic() < deadline, (
                f"the daemon did not serve in {START_TIMEOUT_S:g} s:\n{daemon.notes()}"
            )
            time.sleep(0.05)
    except BaseException:
        kill_daemon(daemon)
        raise
    return daemon


def stop_daemon(daemon: DaemonProcess) -> int:
    """SIGTERM, then SIGKILL if it outlives STOP_TIMEOUT_S; reaps it; its exit code."""
    process = daemon.process
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
    try:
        return process.wait(timeout=STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return kill_daemon(daemon)


def kill_daemon(daemon: DaemonProcess) -> int:
    daemon.process.kill()
    return daemon.process.wait(timeout=STOP_TIMEOUT_S)


def run_cli(*args: str, timeout: float = CLI_TIMEOUT_S) -> subprocess.CompletedProcess[str]:
    """`giraff-console ARGS` to its end, in the test's environment; its output kept."""
    return subprocess.run(
        program(*args),
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=dict(os.environ),
    )


class Heard:
    """A console's listener that keeps every event, in order, and lets a test wait for
    one (the events come on the console's reading thread)."""

    def __init__(self) -> None:
        self._events: list[ServiceEvent] = []
        self._changed = threading.Condition()

    def __call__(self, event: ServiceEvent) -> None:
        with self._changed:
            self._events.append(event)
            self._changed.notify_all()

    def mark(self) -> int:
        """Where the events heard from now on start."""
        with self._changed:
            return len(self._events)

    def since(self, mark: int = 0, kind: type[Event] | None = None) -> list[Event]:
        with self._changed:
            events = self._events[mark:]
        return [e for e in events if kind is None or isinstance(e, kind)]  # type: ignore[misc]

    def latest(self, kind: type[Event]) -> Event | None:
        found = self.since(0, kind)
        return found[-1] if found else None

    def wait_for(self, kind: type[Event], test: Callable[[Event], bool] = lambda e: True,
                 timeout: float = 5.0, since: int = 0, what: str = "") -> Event:  # fmt: skip
        """The first event of `kind` from `since` on that passes `test`; fails the test if
        none comes within `timeout` seconds."""
        deadline = time.monotonic() + timeout
        looked = since
        with self._changed:
            while True:
                for event in self._events[looked:]:
                    if isinstance(event, kind) and test(event):
                        return event
                looked = len(self._events)
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    kinds = [type(e).__name__ for e in self._events[since:]][-20:]
                    raise AssertionError(
                        f"no {what or kind.__name__} in {timeout:g} s; the last heard: {kinds}"
                    )
                self._changed.wait(remaining)


def true_poses(log: Path) -> list[tuple[float, float, float, bool]]:
    """The simulator's true poses from its `--pose-log` (time, x, y, moving), which
    nothing but the tests reads."""
    rows = []
    for line in log.read_text().splitlines():
        parts = line.split()
        if len(parts) == 5:
            rows.append((float(parts[0]), float(parts[1]), float(parts[2]), parts[4] == "1"))
    return rows


def travelled(rows: list[tuple[float, float, float, bool]], since: float = -math.inf) -> float:
    """Metres the true pose went along, from `since` (the pose log's clock)."""
    points = [(x, y) for t, x, y, _ in rows if t >= since]
    return sum(math.dist(a, b) for a, b in itertools.pairwise(points))


def wait_until(test: Callable[[], object], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not test():
        assert time.monotonic() < deadline, f"no {what} in {timeout:g} s"
        time.sleep(0.02)


def distance(a: Pose, b: Pose) -> float:
    return math.hypot(a.x - b.x, a.y - b.y)


def at_rest(telemetry: Telemetry) -> bool:
    """The board says the wheels are still: no MOVING bit, no speed."""
    state = telemetry.state
    return state is not None and not state.moving and abs(state.speed or 0.0) < 1e-3
