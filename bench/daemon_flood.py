"""Benchmark: the daemon under a flood of clients during a `go`, and the operator's stop
(issue 30: the daemon serves clients within bounds, and the stop always wins).

The board is `giraff-console sim --pty --pace --pose-log` in a process of its own (the
control loop on the real clock, as with a real board: with `serve --sim` the loop is
stepped virtually and `late_ms` is always 0), in the example care home's dock; the
daemon is `giraff-console serve --port PTY --at dock --virtual-port` in another, with
the file limit of a usual login session (`--daemon-nofile`, 1024: `ulimit -n`), and
`--max-consoles` when the daemon has it. Each setup has a runtime folder
(XDG_RUNTIME_DIR) of its own. The bench attaches a listener (a console that takes no
controls, keeping each Telemetry's `late_ms` and `loop_hz`) and a driver (a console
that holds the controls). Where the robot really is comes from the simulator's
`--pose-log` (sim/pose_log.py), which the wire never shows.

The phases, in one daemon each setup:

1. **go**: `go room-101` (8.5 m straight north from the dock); once the robot moves,
   the flood's consoles attach and a burst of connection attempts comes; the `go`
   should arrive.
2. **stop by `giraff-console stop`**: `go dock`; once the robot has cruised for 2 s, a
   burst of attempts, and 0.3 s into it the CLI is started: timed from its start.
3. **stop by a console**: `go room-101`; as above, then the driver's `Halt`.
4. **stop by the program on the virtual port**: the driver lets go of the controls
   (`release`) and a program drives by the port (`set a`, `set v`, `set p -0.25`
   renewed every 0.1 s, as the deployed drivers renew their targets: wire-facts); as
   above, then the drivers' stop idiom `set a 0`, `set v 0`, `set p 0`.
5. **after**: the flood hangs up; a new console attaches and drives `go dock`.

For each stop, in seconds after it was sent (the CLI: after its process started): its
answer (the CLI's exit, the reply, the port's prompt); for the CLI, when the daemon told
its consoles the CLI had attached ("seen": its start-up over); when the listener heard
the mission end; when braking began (from the true pose: see `measure_stop`); when the
robot was at rest; and how far it ran from where it was when the stop was sent
(target: braking within 0.2 s, at most 0.3 m). The flood (bench/
console_flood.py, one asyncio process) attaches `--consoles` consoles, `--at-once` at a
time, that say Hello, read everything and beat their hearts, and sends bursts of
`--attempts` connections at once, each held 1 s, saying nothing, junk, or Hello. The
peer: the same setup without the flood ("baseline"), in the same run.

`--busy N` runs N busy loops beside it (`python3 -c 'while 1: pass'`, default 2, as
the issue asks). Every process started is ended whatever happens; every wait has a
timeout.

Usage: python bench/daemon_flood.py [--consoles 300] [--at-once 16] [--attempts 1000]
                                     [--busy 2] [--daemon-nofile 1024] [--no-peer|--no-flood]
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import itertools
import json
import math
import os
import platform
import resource
import select
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the raw port of the driver clients lives with the tests

from giraff_console.robot.loop_events import MissionChanged  # noqa: E402
from giraff_console.robot.safety import RUNAWAY_M  # noqa: E402
from giraff_console.robot.telemetry import Telemetry  # noqa: E402
from giraff_console.service import commands as c  # noqa: E402
from giraff_console.service.events import Controls  # noqa: E402
from giraff_console.service.remote import RemoteRobot  # noqa: E402
from tests.drivers.wire import RawPort, ReplyTimeout  # noqa: E402

FLOORPLAN = ROOT / "giraff_console/floorplans/care-home.yaml"
START_TIMEOUT_S = 30.0
END_TIMEOUT_S = 10.0
MISSION_TIMEOUT_S = 120.0
FLOOD_TIMEOUT_S = 60.0
CRUISE_S = 2.0  # moving this long before a stop is sent
INTO_BURST_S = 0.3  # the stop goes this long after a burst of attempts began
REST_S = 0.5  # no change of the true pose for this long: at rest
REST_TIMEOUT_S = 10.0
STOP_TARGET_S = 0.2  # issue 30
LATE_TARGET_MS = 5.0  # issue 30
HOLD_S = 1.0  # each attempt holds its connection this long


# -- processes -------------------------------------------------------------------------


def end_process(process: subprocess.Popen, sig: int = signal.SIGTERM) -> None:
    """`sig`, then SIGKILL if it outlives END_TIMEOUT_S; reaped either way."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            process.send_signal(sig)
        try:
            process.wait(END_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(END_TIMEOUT_S)


def first_line(process: subprocess.Popen, what: str) -> str:
    assert process.stdout is not None
    if not select.select([process.stdout], [], [], START_TIMEOUT_S)[0]:
        raise RuntimeError(f"{what} printed nothing in {START_TIMEOUT_S:g} s")
    line = process.stdout.readline().decode().strip()
    if not line:
        raise RuntimeError(f"{what} ended before printing its port")
    return line


@dataclass(frozen=True)
class Sample:
    at: float  # the pose log's clock: time.monotonic() in the simulator's process
    x: float
    y: float


class PoseLog:
    """The simulator's true pose, read as its `--pose-log` grows."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.samples: list[Sample] = []
        self.times: list[float] = []  # the samples', for bisect
        self._offset = 0

    def read(self) -> list[Sample]:
        with contextlib.suppress(FileNotFoundError), self.path.open("rb") as file:
            file.seek(self._offset)
            data = file.read()
            whole = data[: data.rfind(b"\n") + 1]
            self._offset += len(whole)
            for line in whole.decode().splitlines():
                t, x, y, _, _ = line.split()
                self.samples.append(Sample(float(t), float(x), float(y)))
                self.times.append(float(t))
        return self.samples

    def between(self, begin: float, end: float) -> list[Sample]:
        """The samples from `begin` to `end`, read so far."""
        self.read()
        return self.samples[bisect.bisect_left(self.times, begin) :
                            bisect.bisect_right(self.times, end)]  # fmt: skip

    def speed(self, at: float, span: float = 0.1) -> float:
        """The true speed over the `span` seconds before `at`, m/s."""
        window = self.between(at - span, at)
        if len(window) < 2 or window[-1].at <= window[0].at:
            return 0.0
        run = sum(math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(window))
        return run / (window[-1].at - window[0].at)

    def wait_moving(self, seconds: float, timeout: float) -> None:
        """Until the robot has been moving for `seconds`; RuntimeError after `timeout`."""
        deadline, since = time.monotonic() + timeout, None
        while True:
            now = time.monotonic()
            if self.speed(now) > 0.05:
                since = since or now
                if now - since >= seconds:
                    return
            else:
                since = None
            if now > deadline:
                raise RuntimeError(f"the robot did not move for {seconds:g} s")
            time.sleep(0.05)

    def rest_after(self, sent: float) -> Sample | None:
        """The first sample after `sent` from which the pose stays put REST_S; waits up
        to REST_TIMEOUT_S for it."""
        deadline = time.monotonic() + REST_TIMEOUT_S
        while time.monotonic() < deadline:
            after = self.between(sent, math.inf)
            # The first of the run of samples at the last one's place, if it is long enough.
            n = len(after) - 1
            while n > 0 and (after[n - 1].x, after[n - 1].y) == (after[-1].x, after[-1].y):
                n -= 1
            if after and after[-1].at - after[n].at >= REST_S:
                return after[n]
            time.sleep(0.1)
        return None


# -- consoles --------------------------------------------------------------------------


@dataclass(frozen=True)
class Tick:
    at: float
    late_ms: float
    loop_hz: float


class Listener:
    """A console that takes no controls and keeps each tick and each mission's end."""

    def __init__(self, socket: Path) -> None:
        self.ticks: list[Tick] = []
        self.ends: list[tuple[float, MissionChanged]] = []
        self.controls: list[tuple[float, Controls]] = []
        self.robot = RemoteRobot(socket, "bench-listener", take=False)
        self.robot.subscribe(self._hear)

    def _hear(self, event: object) -> None:  # on the client's reading thread
        if isinstance(event, Telemetry):
            self.ticks.append(Tick(time.monotonic(), event.late_ms, event.loop_hz))
        elif isinstance(event, MissionChanged) and not event.running:
            self.ends.append((time.monotonic(), event))
        elif isinstance(event, Controls):
            self.controls.append((time.monotonic(), event))

    def seen(self, console: str, since: float) -> float | None:
        """When the daemon first told of a console named `console …` attached, after
        `since`: `giraff-console stop` is there, its start-up over."""
        for at, told in self.controls:
            if at >= since and any(name.startswith(console) for name in told.consoles):
                return at
        return None

    def wait_end(self, since: int, timeout: float) -> MissionChanged | None:
        deadline = time.monotonic() + timeout
        while len(self.ends) <= since and time.monotonic() < deadline:
            time.sleep(0.05)
        return self.ends[since][1] if len(self.ends) > since else None


class Flood:
    """bench/console_flood.py in a process of its own, asked a line at a time."""

    def __init__(self, socket: Path, stack: contextlib.ExitStack) -> None:
        self.process = subprocess.Popen(
            [sys.executable, str(ROOT / "bench/console_flood.py"), str(socket)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            start_new_session=True,
        )  # fmt: skip
        stack.callback(end_process, self.process, signal.SIGKILL)

    def send(self, line: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line.encode() + b"\n")
        self.process.stdin.flush()

    def answer(self, timeout: float = FLOOD_TIMEOUT_S) -> dict[str, object]:
        assert self.process.stdout is not None
        if not select.select([self.process.stdout], [], [], timeout)[0]:
            raise RuntimeError(f"the flood did not answer in {timeout:g} s")
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError("the flood ended")
        return dict(json.loads(line))


class Program:
    """A program on the virtual port, driving by the board's protocol."""

    def __init__(self, path: str) -> None:
        self.port = RawPort.open(path)
        self.port.read_to_prompt(START_TIMEOUT_S)  # the greeting
        self._exit = threading.Event()
        self._renewer: threading.Thread | None = None

    def ask(self, line: str) -> str:
        self.port.write(line.encode() + b"\r")
        return self.port.read_to_prompt(5.0).decode(errors="replace").strip()

    def drive(self) -> None:
        """Backwards (south, the corridor's way) at 0.3 m/s, the target renewed."""
        for line in ("set a 0.5", "set v 0.3"):
            self.ask(line)

        def renew() -> None:
            with contextlib.suppress(ReplyTimeout):  # a daemon too slow to answer: no more
                while not self._exit.wait(0.1):
                    self.ask("set p -0.25")

        self._renewer = threading.Thread(target=renew, name="bench-program", daemon=True)
        self._renewer.start()

    def stop(self) -> float:
        """The drivers' stop idiom once the renewing has ended; when it began."""
        self._exit.set()
        if self._renewer is not None:
            self._renewer.join(5.0)
        sent = time.monotonic()
        for line in ("set a 0", "set v 0", "set p 0"):
            self.ask(line)
        return sent

    def close(self) -> None:
        self._exit.set()
        if self._renewer is not None:
            self._renewer.join(10.0)  # its last ask times out within 5 s
        self.port.close()


# -- one setup -------------------------------------------------------------------------


@dataclass
class Stop:
    path: str
    speed: float  # m/s, when sent
    answered_s: float | None  # the CLI's exit, the reply, the port's prompt
    seen_s: float | None  # the CLI attached, as the daemon told its consoles
    ended_s: float | None  # the listener heard the mission end (none on the port)
    braking_s: float | None
    rest_s: float | None
    run_on_m: float | None
    note: str = ""


@dataclass
class Result:
    name: str
    phases: dict[str, tuple[float, float]] = field(default_factory=dict)  # start, end
    ticks: list[Tick] = field(default_factory=list)
    go: str = "-"
    stops: list[Stop] = field(default_factory=list)
    flood: list[str] = field(default_factory=list)
    after: str = "-"
    daemon: str = "-"
    peak: str = "-"
    cli_idle_s: float | None = None  # `giraff-console stop` with the robot standing
    failed: list[str] = field(default_factory=list)


def measure_stop(poses: PoseLog, path: str, sent: float, answered: float | None,
                 ended: float | None, note: str = "",
                 seen: float | None = None) -> Stop:  # fmt: skip
    """How the stop sent at `sent` went, by the true pose. The robot cruises at `speed`
    until braking begins, B seconds after `sent`, then slows evenly to rest, R seconds
    after `sent`, having run s metres: s = speed * B + speed * (R - B) / 2, so
    B = 2 s / speed - R. This reads braking's start from the whole stop rather than from
    a speed estimated over a few 20 ms samples, which lags by the samples it averages."""
    speed = poses.speed(sent)
    rest = poses.rest_after(sent)
    if rest is None or speed <= 0:
        return Stop(path, speed, answered, seen, ended, None, None, None, note or "never at rest")
    track = poses.between(-math.inf, sent)[-1:] + poses.between(sent, rest.at)
    ran = sum(math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(track))
    resting = rest.at - sent
    braking = 2 * ran / speed - resting
    # Outside 0..`resting`: the robot was not cruising evenly until the stop braked it (a
    # stop so late that the mission's own slowing came first, or a loop too late to hold
    # a speed): no figure rather than a wrong one.
    return Stop(path, speed, answered, seen, ended,
                braking if 0 <= braking <= resting else None, resting, ran, note)  # fmt: skip


def run_setup(name: str, folder: Path, args: argparse.Namespace, flooded: bool) -> Result:
    result = Result(name)
    folder.mkdir(mode=0o700)
    env = {**os.environ, "XDG_RUNTIME_DIR": str(folder), "XDG_CONFIG_HOME": str(folder / "cfg"),
           "XDG_DATA_HOME": str(folder / "data")}  # fmt: skip
    with contextlib.ExitStack() as stack:
        poses = PoseLog(folder / "pose.log")
        sim = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "sim", "--pty", "--pace", "--floorplan",
             str(FLOORPLAN), "--pose-log", str(poses.path)],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, start_new_session=True,
        )  # fmt: skip
        stack.callback(end_process, sim)
        board = first_line(sim, "the simulator")
        extra = ["--max-consoles", str(args.max_consoles)] if args.max_consoles else []
        nofile = args.daemon_nofile

        def limit_files() -> None:  # in the daemon's process, before it starts
            _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
            resource.setrlimit(resource.RLIMIT_NOFILE, (min(nofile, hard), hard))

        with (folder / "daemon.log").open("wb") as log:
            daemon = subprocess.Popen(
                [sys.executable, "-m", "giraff_console", "serve", "--port", board, "--at",
                 "dock", "--virtual-port", *extra],
                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=log, env=env,
                start_new_session=True, preexec_fn=limit_files,
            )  # fmt: skip
        stack.callback(end_process, daemon)
        virtual_port = first_line(daemon, "the daemon")
        socket = folder / "giraff-console" / "robot.sock"
        deadline = time.monotonic() + START_TIMEOUT_S
        while not socket.exists():
            if time.monotonic() > deadline:
                raise RuntimeError("the daemon's socket never came")
            time.sleep(0.1)
        peak = Peak(daemon.pid)
        stack.callback(peak.close)
        listener = Listener(socket)
        stack.callback(listener.robot.close)
        driver = RemoteRobot(socket, "bench-driver", take=True)
        stack.callback(driver.close)
        flood = Flood(socket, stack) if flooded else None

        def burst() -> None:
            if flood is not None:
                flood.send(f"attempts {args.attempts} {HOLD_S}")
                time.sleep(INTO_BURST_S)

        def burst_heard() -> None:
            if flood is not None:
                result.flood.append(f"{args.attempts} attempts: {flood.answer()}")

        def go(room: str) -> int:
            since = len(listener.ends)
            reply = driver.execute(c.Go(room))
            if not reply.ok:
                raise RuntimeError(f"go {room} refused: {reply.text}")
            return since

        def phase(label: str, run: Callable[[], None]) -> None:
            began = time.monotonic()
            try:
                run()
            except Exception as error:  # told in the table: the next phase goes on
                result.failed.append(f"{label}: {type(error).__name__}: {error}")
            finally:
                result.phases[label] = (began, time.monotonic())

        def ended_since(mark: int, sent: float) -> float | None:
            """When the listener heard the mission end, after `sent`, waiting a little."""
            deadline = time.monotonic() + REST_TIMEOUT_S
            while len(listener.ends) <= mark and time.monotonic() < deadline:
                time.sleep(0.02)
            return listener.ends[mark][0] - sent if len(listener.ends) > mark else None

        def cli(timeout: float) -> tuple[float | None, str]:
            """`giraff-console stop`, timed from its start: its time and its end."""
            began = time.monotonic()
            try:
                done = subprocess.run([sys.executable, "-m", "giraff_console", "stop"],
                                      env=env, capture_output=True, timeout=timeout)  # fmt: skip
            except subprocess.TimeoutExpired:
                return None, f"no exit in {timeout:g} s"
            return time.monotonic() - began, f"exit {done.returncode}"

        def go_phase() -> None:
            result.cli_idle_s, _ = cli(60.0)
            since = go("room-101")
            poses.wait_moving(0.5, 30.0)
            if flood is not None:
                flood.send(f"attach {args.consoles} {args.at_once}")
                result.flood.append(f"{args.consoles} consoles: {flood.answer()}")
                flood.send(f"attempts {args.attempts} {HOLD_S}")
                burst_heard()
            began = time.monotonic()
            end = listener.wait_end(since, MISSION_TIMEOUT_S)
            result.go = (f"{end.end.outcome.value} ({time.monotonic() - began:.0f} s after the "
                         "flood)" if end is not None and end.end is not None
                         else f"no end in {MISSION_TIMEOUT_S:g} s")  # fmt: skip

        def cli_stop() -> None:
            go("dock")
            poses.wait_moving(CRUISE_S, 30.0)
            burst()
            mark, sent = len(listener.ends), time.monotonic()
            answered, said = cli(60.0)
            seen = listener.seen("stop", sent)
            result.stops.append(measure_stop(poses, "giraff-console stop", sent, answered,
                                             ended_since(mark, sent), said,
                                             None if seen is None else seen - sent))  # fmt: skip
            burst_heard()

        def console_stop() -> None:
            go("room-101")
            poses.wait_moving(CRUISE_S, 30.0)
            burst()
            mark, sent = len(listener.ends), time.monotonic()
            replies: list[float] = []
            driver.post(c.Halt(), lambda reply: replies.append(time.monotonic()))
            stop = measure_stop(poses, "a console's Halt", sent, None, ended_since(mark, sent))
            stop.answered_s = replies[0] - sent if replies else None
            result.stops.append(stop)
            burst_heard()

        def program_stop() -> None:
            released = driver.execute(c.Release())
            if not released.ok:
                raise RuntimeError(f"release refused: {released.text}")
            program = Program(virtual_port)
            try:
                program.drive()
                poses.wait_moving(CRUISE_S, 30.0)
                burst()
                sent = program.stop()
                answered = time.monotonic() - sent
                result.stops.append(measure_stop(poses, "the virtual port's set p 0", sent,
                                                 answered, None))  # fmt: skip
            finally:
                program.close()  # hanging up lets go of the controls it took, and stops it
            burst_heard()

        def after() -> None:
            if flood is not None:
                flood.send("end")
                result.flood.append(f"ended: {flood.answer()}")
            began = time.monotonic()
            fresh = RemoteRobot(socket, "bench-after", take=True)
            attached = time.monotonic() - began
            try:
                since = len(listener.ends)
                reply = fresh.execute(c.Go("dock"))
                end = listener.wait_end(since, MISSION_TIMEOUT_S) if reply.ok else None
                said = (end.end.outcome.value if end is not None and end.end is not None
                        else reply.text or "no end")  # fmt: skip
                result.after = f"attached in {attached:.2f} s; go dock: {said}"
            finally:
                fresh.close()

        for label, run in (("go", go_phase), ("stop: CLI", cli_stop),
                           ("stop: console", console_stop),
                           ("stop: virtual port", program_stop), ("after", after)):  # fmt: skip
            if daemon.poll() is not None:
                result.failed.append(f"{label}: not run, the daemon has ended")
                continue
            print(f"  {name}: {label} ...", file=sys.stderr, flush=True)
            phase(label, run)
        result.ticks = list(listener.ticks)
        result.peak = peak.said()
        status = daemon.poll()
        result.daemon = "alive" if status is None else f"ended, status {status}"
        if status is not None:
            result.daemon += ": " + (folder / "daemon.log").read_text(errors="replace")[-300:]
    return result


class Peak:
    """The daemon's most threads and open descriptors, looked at twice a second."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.threads = self.files = 0
        self._exit = threading.Event()
        self._thread = threading.Thread(target=self._look, name="bench-peak", daemon=True)
        self._thread.start()

    def _look(self) -> None:
        while not self._exit.wait(0.5):
            with contextlib.suppress(OSError):
                self.threads = max(self.threads, len(os.listdir(f"/proc/{self.pid}/task")))
                self.files = max(self.files, len(os.listdir(f"/proc/{self.pid}/fd")))

    def said(self) -> str:
        return f"{self.threads} threads, {self.files} descriptors"

    def close(self) -> None:
        self._exit.set()
        self._thread.join(2.0)


# -- figures ---------------------------------------------------------------------------


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(share * (len(ordered) - 1)))]


def tick_row(name: str, label: str, ticks: list[Tick]) -> str:
    if len(ticks) < 2:
        return f"{name:<10}{label:<20}{len(ticks):>6}  (too few ticks heard)"
    late = [t.late_ms for t in ticks]
    hz = statistics.median(t.loop_hz for t in ticks)
    heard = (len(ticks) - 1) / (ticks[-1].at - ticks[0].at)
    return (f"{name:<10}{label:<20}{len(ticks):>6}{heard:>7.1f}{hz:>6.0f}"
            f"{percentile(late, 0.5):>8.2f}{percentile(late, 0.99):>8.2f}{max(late):>9.2f}"
            f"{sum(x > LATE_TARGET_MS for x in late):>6}")  # fmt: skip


def figure(value: float | None, form: str) -> str:
    return "-" if value is None else format(value, form)


def report(results: list[Result]) -> None:
    print("ticks (late_ms as the loop reports it)   heard    Hz  loop     p50     p99"
          "      max   >5ms")  # fmt: skip
    for r in results:
        for label, (began, ended) in r.phases.items():
            print(tick_row(r.name, label, [t for t in r.ticks if began <= t.at <= ended]))
        if r.phases:
            began = min(b for b, _ in r.phases.values())
            ended = max(e for _, e in r.phases.values())
            print(tick_row(r.name, "all", [t for t in r.ticks if began <= t.at <= ended]))
    print()
    print("stops, s after sent                   speed  answered   seen  ended  braking  at rest"
          "  ran on")  # fmt: skip
    print(f"{'':<38}m/s{'':<51}m")
    for r in results:
        for s in r.stops:
            print(f"{r.name:<10}{s.path:<27}{s.speed:>6.2f}{figure(s.answered_s, '10.3f'):>10}"
                  f"{figure(s.seen_s, '7.3f'):>7}"
                  f"{figure(s.ended_s, '7.3f'):>7}{figure(s.braking_s, '9.3f'):>9}"
                  f"{figure(s.rest_s, '9.3f'):>9}{figure(s.run_on_m, '8.3f'):>8}"
                  f"  {s.note}")  # fmt: skip
    print()
    for r in results:
        print(f"{r.name}: the daemon {r.daemon}; at most {r.peak}")
        print(f"{r.name}: go room-101: {r.go}; after: {r.after}")
        print(
            f"{r.name}: `giraff-console stop` with the robot standing, no flood: "
            f"{figure(r.cli_idle_s, '.3f')} s (the CLI's start-up is in each CLI figure)"
        )
        for line in r.flood:
            print(f"{r.name}: flood: {line}")
        for failed in r.failed:
            print(f"{r.name}: NOT FINISHED: {failed}")
    for r in results:
        if r.name != "flood":
            continue
        began = min((b for b, _ in r.phases.values()), default=0.0)
        late = [t.late_ms for t in r.ticks if t.at >= began]
        p99 = percentile(late, 0.99) if late else math.inf
        paths = "; ".join(
            f"{s.path}: braking {met(s.braking_s is not None and s.braking_s <= STOP_TARGET_S)}"
            f", ran on {met(s.run_on_m is not None and s.run_on_m <= RUNAWAY_M)}"
            for s in r.stops)  # fmt: skip
        print(f"targets under the flood: the daemon alive: {met(r.daemon == 'alive')}; tick "
              f"lateness p99 {p99:.2f} ms <= {LATE_TARGET_MS:g}: {met(p99 <= LATE_TARGET_MS)}; "
              f"the go arrived: {met(r.go.startswith('arrived'))}; the new console drove: "
              f"{met('go dock: arrived' in r.after)}")  # fmt: skip
        print(f"stops under the flood (within {STOP_TARGET_S:g} s, at most {RUNAWAY_M:g} m): "
              f"{paths}")  # fmt: skip


def met(target: bool) -> str:
    return "met" if target else "NOT MET"


# -- main ------------------------------------------------------------------------------


def cpu_model() -> str:
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as cpuinfo:
        for line in cpuinfo:
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown CPU"


def loadavg() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def has_max_consoles() -> bool:
    """Whether this daemon takes `--max-consoles` (issue 30's connection limit)."""
    said = subprocess.run([sys.executable, "-m", "giraff_console", "serve", "--help"],
                          capture_output=True, text=True, timeout=60)  # fmt: skip
    return "--max-consoles" in said.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--consoles", type=int, default=300, help="consoles the flood attaches")
    parser.add_argument("--at-once", type=int, default=16, metavar="K",
                        help="consoles attaching at the same time (default 16)")  # fmt: skip
    parser.add_argument("--attempts", type=int, default=1000,
                        help="connection attempts in each burst")  # fmt: skip
    parser.add_argument("--busy", type=int, default=2, metavar="N",
                        help="busy loops to run beside the benchmark (default 2)")  # fmt: skip
    parser.add_argument("--daemon-nofile", type=int, default=1024, metavar="N",
                        help="the daemon's open file limit (default: a login "
                        "session's)")  # fmt: skip
    parser.add_argument("--no-peer", action="store_true", help="only the flooded daemon")
    parser.add_argument("--no-flood", action="store_true", help="only the peer")
    args = parser.parse_args()
    # Room for the flood's consoles, the bench's own and the stops; the rest refused.
    args.max_consoles = args.consoles + 20 if has_max_consoles() else None
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    folder = Path(tempfile.mkdtemp(prefix="giraff-flood-", dir="/tmp"))
    busy: list[subprocess.Popen] = []
    results: list[Result] = []
    began, load_before = time.monotonic(), loadavg()
    try:
        busy = [subprocess.Popen(["python3", "-c", "while 1: pass"]) for _ in range(args.busy)]
        wanted = {"baseline": not args.no_peer, "flood": not args.no_flood}
        setups = [(name, name == "flood") for name, run in wanted.items() if run]
        for n, (name, flooded) in enumerate(setups):
            print(f"{name} ...", file=sys.stderr, flush=True)
            results.append(run_setup(name, folder / str(n), args, flooded))
        load_after = loadavg()
    finally:
        for loop in busy:
            end_process(loop, signal.SIGKILL)
        shutil.rmtree(folder, ignore_errors=True)
    import giraff_console

    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {cpu_model()}, {os.cpu_count()} cores, Linux "
          f"{platform.release()}")  # fmt: skip
    print(f"load: {args.busy} busy loops beside it; load average {load_before} at the start, "
          f"{load_after} at the end; {time.monotonic() - began:.0f} s; flood: "
          f"{args.consoles} consoles ({args.at_once} at a time), bursts of {args.attempts} "
          f"attempts; the daemon's file "
          f"limit {args.daemon_nofile}; --max-consoles "
          f"{args.max_consoles or '(not in this daemon)'}")  # fmt: skip
    print()
    report(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
