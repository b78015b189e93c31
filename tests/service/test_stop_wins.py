"""The operator's stop wins over a flood of clients (issue 30, Deliver 3), at the size
of a test: bench/daemon_flood.py measures the strict figures (0.2 s, 300 consoles,
1,000 attempts, beside busy loops).

The real daemon (`giraff-console serve --sim --max-consoles 210`) in a child process,
with a login session's file limit (1024) whatever the machine's; the flood is
bench/console_flood.py in a process of its own: 200 consoles, 16 attaching at a time,
that say Hello, read everything and beat their hearts, and bursts of 200 connection
attempts held a second each. (Issue 30 saw the daemon of a thread per console answer
`stop` in 6.2 s with 340 consoles attached; that daemon does not take these 200 within
FLOOD_WAIT_S.) During a `go`, `giraff-console stop` and a console's stop must
each end the mission within STOP_S (the CLI's CLI_START_S more, from its start) and
bring the robot to rest; the daemon lives, and afterwards a new console attaches and
drives.

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
CONSOLES = 200
AT_ONCE = 16  # consoles attaching at the same time, as if started over a few seconds
# Room for the flood's consoles, the test's own and the CLI; the attempts beyond it.
LIMIT = ("--max-consoles", "210")
ATTEMPTS = 200
# The daemon's open file limit: a login session's (`ulimit -n`), as on a robot's PC,
# whatever the test machine's.
DAEMON_FILES = 1024
# Seconds a stop may take to end the mission: generous beside the 0.2 s (the
# bench's), yet far below the 6.2 s issue 30 saw with 340 consoles attached.
STOP_S = 1.0
# A Python program's start on a machine as loaded as the suite's (the bench times it).
CLI_START_S = 1.0
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
            program("serve", "--sim", "--no-landmarks", *LIMIT), stdin=subprocess.DEVNULL,
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
        line = self.process.stdout.readline()
        assert line, f"the flood ended ({self.process.poll()})"
        return dict(json.loads(line))

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


class Told:
    """When the daemon told its consoles of each mission's end (time.monotonic(), on the
    listener's reading thread)."""

    def __init__(self) -> None:
        self.heard: list[tuple[float, MissionChanged]] = []

    def __call__(self, event: object) -> None:
        if isinstance(event, MissionChanged):
            self.heard.append((time.monotonic(), event))

    def ended(self, since: float) -> float:
        """When a mission's end was first told, after `since`."""
        for at, event in list(self.heard):
            if at >= since and isinstance(event, MissionChanged) and not event.running:
                return at
        raise AssertionError("no mission's end told after the stop was sent")


def stopped_within(heard: Heard, told: Told, mark: int, sent: float, allowed: float,
                   who: str) -> None:  # fmt: skip
    """The mission ends within `allowed` s of `sent`, and the robot comes to rest."""
    heard.wait_for(MissionChanged, lambda e: not e.running, WAIT_S + allowed, since=mark,
                   what=f"the mission's end after {who}")  # fmt: skip
    took = told.ended(sent) - sent
    assert took <= allowed, f"{who} ended the mission {took:.2f} s after it was sent"
    heard.wait_for(Telemetry, at_rest, BRAKE_S, since=heard.mark(),
                   what=f"the robot at rest after {who}")  # fmt: skip


def test_the_operator_s_stop_wins_over_a_flood_of_clients(daemon, flood):
    heard, told = Heard(), Told()
    listener = RemoteRobot(daemon.socket, "listener", take=False)
    driver = RemoteRobot(daemon.socket, "driver", take=True)
    try:
        listener.subscribe(heard)
        listener.subscribe(told)
        flood.send(f"attach {CONSOLES} {AT_ONCE}")
        attached = flood.answer()
        assert attached["attached"] == CONSOLES, attached

        drive(driver, heard)
        flood.send(f"attempts {ATTEMPTS} 1.0")
        time.sleep(INTO_BURST_S)
        mark, sent = heard.mark(), time.monotonic()
        stopped = run_cli("stop")
        assert stopped.returncode == 0, stopped.stderr
        # Timed from the command's start: its own start-up counts (0.14 s on an idle
        # 2-core PC, service/stop_request.py), so it has CLI_START_S more.
        stopped_within(heard, told, mark, sent, STOP_S + CLI_START_S, "`giraff-console stop`")
        flood.answer()

        drive(driver, heard)
        flood.send(f"attempts {ATTEMPTS} 1.0")
        time.sleep(INTO_BURST_S)
        mark, sent = heard.mark(), time.monotonic()
        driver.post(c.Halt())
        stopped_within(heard, told, mark, sent, STOP_S, "a console's stop")
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
            stopped_within(heard, told, mark, sent, STOP_S, "the fresh console's stop")
        finally:
            fresh.close()
    finally:
        driver.close()
        listener.close()
