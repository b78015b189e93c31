"""The operator's stop wins over a flood of clients (issue 30, Deliver 3), at the size
of a test: bench/daemon_flood.py measures the strict figures (0.2 s, 300 consoles,
1,000 attempts, beside busy loops).

The real daemon (`giraff-console serve --sim`) in a child process, with a file limit
of 128 so that the flood reaches it as 1,000 connections reach a login session's 1024;
the flood is bench/console_flood.py in a process of its own: 60 consoles that say
Hello, read everything and beat their hearts, and bursts of 200 connection attempts
held a second each. During a `go`, `giraff-console stop` and a console's stop must
each end the mission within STOP_S (the CLI's own start-up, measured first on the
idle daemon, aside) and bring the robot to rest; the daemon lives, and afterwards a
new console attaches and drives.

Every wait has a timeout, and every process is ended whatever the test does.
"""

from __future__ import annotations

import json
import os
import resource
import select
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.remote import RemoteRobot
from tests.service.daemon_rig import (
    SERVING,
    START_TIMEOUT_S,
    DaemonProcess,
    Heard,
    at_rest,
    program,
    run_cli,
    stop_daemon,
)

FLOOD = Path(__file__).resolve().parents[2] / "bench" / "console_flood.py"
CONSOLES = 60  # beside the listener and the driver, within the default --max-consoles 64
AT_ONCE = 16  # consoles attaching at the same time
ATTEMPTS = 200
# The daemon's open file limit: the 200 attempts, held at once beside the 60 consoles,
# run past it, as 1,000 connections run past a login session's 1024 (issue 30).
DAEMON_FILES = 128
# Seconds a stop may take to end the mission: generous beside the 0.2 s (the
# bench's), yet far below the 6.2 s issue 30 saw with 340 consoles attached.
STOP_S = 1.0
# Seconds from the mission's end to rest: a brake from 0.4 m/s at 0.5 m/s^2, and slack.
BRAKE_S = 0.8 + 0.4
WAIT_S = 10.0
FLOOD_WAIT_S = 20.0
INTO_BURST_S = 0.3


@pytest.fixture
def runtime(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A runtime folder of the test's own, for this process and the children alike, and
    an empty settings folder."""
    folder = Path(tempfile.mkdtemp(prefix="gw-", dir="/tmp"))
    (folder / "config").mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(folder / "config"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def limit_files() -> None:
    """In the daemon's process, before it starts."""
    _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(DAEMON_FILES, hard), hard))


@pytest.fixture
def daemon(runtime: Path) -> Iterator[DaemonProcess]:
    log = runtime / "serve.log"
    with log.open("wb") as errors:
        process = subprocess.Popen(
            program("serve", "--sim", "--no-landmarks"), stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=errors, env=dict(os.environ),
            preexec_fn=limit_files,
        )  # fmt: skip
    served = DaemonProcess(process, runtime / "giraff-console" / "robot.sock", log)
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not (SERVING in served.notes() and served.socket.exists()):
            assert served.alive(), f"the daemon ended before serving:\n{served.notes()}"
            assert time.monotonic() < deadline, f"the daemon did not serve:\n{served.notes()}"
            time.sleep(0.05)
        yield served
    finally:
        stop_daemon(served)


class Flood:
    """bench/console_flood.py in a process of its own, asked a line at a time."""

    def __init__(self, socket: Path) -> None:
        self.process = subprocess.Popen(
            [sys.executable, str(FLOOD), str(socket)], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        )  # fmt: skip

    def send(self, line: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line.encode() + b"\n")
        self.process.stdin.flush()

    def answer(self) -> dict[str, object]:
        assert self.process.stdout is not None
        ready = select.select([self.process.stdout], [], [], FLOOD_WAIT_S)[0]
        assert ready, f"the flood did not answer in {FLOOD_WAIT_S:g} s"
        return dict(json.loads(self.process.stdout.readline()))

    def close(self) -> None:
        self.process.kill()
        self.process.wait(WAIT_S)


@pytest.fixture
def flood(daemon: DaemonProcess) -> Iterator[Flood]:
    started = Flood(daemon.socket)
    try:
        yield started
    finally:
        started.close()


def moving(telemetry: Telemetry) -> bool:
    state = telemetry.state
    return state is not None and state.moving and abs(state.speed or 0.0) > 0.1


def drive(driver: RemoteRobot, heard: Heard) -> None:
    """`go room-101` (straight north from the dock), until the robot moves."""
    mark = heard.mark()
    reply = driver.execute(c.Go("room-101"), timeout=WAIT_S)
    assert reply.ok, reply.text
    heard.wait_for(Telemetry, moving, WAIT_S, since=mark, what="the robot moving")


def stopped_within(heard: Heard, mark: int, sent: float, allowed: float, who: str) -> None:
    """The mission ends within `allowed` s of `sent`, and the robot comes to rest."""
    ended = heard.wait_for(MissionChanged, lambda e: not e.running, WAIT_S + allowed,
                           since=mark, what=f"the mission's end after {who}")  # fmt: skip
    took = time.monotonic() - sent
    assert ended.end is not None
    assert took <= allowed, f"{who} ended the mission {took:.2f} s after it was sent"
    heard.wait_for(Telemetry, at_rest, BRAKE_S, since=heard.mark(),
                   what=f"the robot at rest after {who}")  # fmt: skip


def test_the_operator_s_stop_wins_over_a_flood_of_clients(daemon, flood):
    heard = Heard()
    listener = RemoteRobot(daemon.socket, "listener", take=False)
    driver = RemoteRobot(daemon.socket, "driver", take=True)
    try:
        listener.subscribe(heard)
        began = time.monotonic()
        assert run_cli("stop").returncode == 0  # the robot standing: the CLI's start-up
        cli_s = time.monotonic() - began
        flood.send(f"attach {CONSOLES} {AT_ONCE}")
        attached = flood.answer()
        assert attached["attached"] == CONSOLES, attached

        drive(driver, heard)
        flood.send(f"attempts {ATTEMPTS} 1.0")
        time.sleep(INTO_BURST_S)
        mark, sent = heard.mark(), time.monotonic()
        stopped = run_cli("stop", timeout=WAIT_S + cli_s)
        assert stopped.returncode == 0, stopped.stderr
        stopped_within(heard, mark, sent, cli_s + STOP_S, "`giraff-console stop`")
        flood.answer()

        drive(driver, heard)
        flood.send(f"attempts {ATTEMPTS} 1.0")
        time.sleep(INTO_BURST_S)
        mark, sent = heard.mark(), time.monotonic()
        driver.post(c.Halt())
        stopped_within(heard, mark, sent, STOP_S, "a console's stop")
        flood.answer()
        assert daemon.alive(), f"the daemon ended ({daemon.process.returncode}):\n{daemon.notes()}"

        flood.send("end")
        flood.answer()
        driver.close()
        fresh = RemoteRobot(daemon.socket, "fresh", take=True)
        try:
            drive(fresh, heard)
            mark, sent = heard.mark(), time.monotonic()
            fresh.post(c.Halt())
            stopped_within(heard, mark, sent, STOP_S, "the fresh console's stop")
        finally:
            fresh.close()
    finally:
        driver.close()
        listener.close()
