"""Benchmark: the socket fuzz (issue 30, Done-when: "The socket fuzz (malformed,
truncated, oversized, wrong types, 10,000 cases) finds 0 exception texts in replies, 0
crashes and 0 ticks later than 5 ms").

The board is `giraff-console sim --pty --pace --pose-log FILE` in a process of its own
(the loop on the real clock, as with a real board: with `serve --sim` the loop is
stepped virtually and `late_ms` is always 0), the daemon `giraff-console serve --port
PTY --at dock` in another, in a runtime folder of the run's own. A listener console
(RemoteRobot, take=False) keeps every Telemetry's `late_ms` and `loop_hz`. Beside `--busy N` busy
loops (`python3 -c 'while 1: pass'`, default 2, always ended):

- "quiet": the listener alone for `--quiet-seconds`: the peer, the lateness this
  machine gives the loop with no junk;
- "fuzz": `--count` junk lines (tests/service/socket_junk.py, seed 30, 10,000 by
  default) over the real socket, BURST at a time, each burst's answers waited for.

Then a new console's `status`. Printed: the lines by kind; answers, and those holding
Python's own words (the daemon's and the transport's refusals apart); consoles hung up
on; the daemon alive and answering; the true pose's travel (the simulator's pose log,
which the wire never shows); and for each window the ticks heard, late_ms p50, p99 and
max, and how many ticks were later than 5 ms.

Usage: python bench/socket_fuzz.py [--count N] [--seed S] [--busy N] [--quiet-seconds S]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from giraff_console.robot.telemetry import Telemetry  # noqa: E402
from giraff_console.service.remote import RemoteRobot  # noqa: E402
from tests.service.daemon_rig import travelled, true_poses  # noqa: E402
from tests.service.socket_junk import SEED, pelt, status_after  # noqa: E402

LATE_MS = 5.0  # the Done-when's bound on a tick's lateness
SIM_TIMEOUT_S = 20.0
SOCKET_TIMEOUT_S = 30.0
START_SETTLE_S = 1.0
END_TIMEOUT_S = 10.0
# The daemon's answer to the first junk must not be waited for before the listener hears.
FIRST_TICK_TIMEOUT_S = 20.0


def end_process(process: subprocess.Popen[bytes], sig: int = signal.SIGTERM) -> None:
    """`sig`, then SIGKILL if it outlives END_TIMEOUT_S; reaped either way."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            process.send_signal(sig)
        try:
            process.wait(END_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(END_TIMEOUT_S)


def start_board(stack: contextlib.ExitStack, folder: Path) -> str:
    """The simulated board on a pty, paced as a 115200-baud line; its pty's path."""
    with (folder / "sim.log").open("wb") as errors:
        process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "sim", "--pty", "--pace",
             "--pose-log", str(folder / "poses.txt"), "--floorplan",
             str(ROOT / "giraff_console/floorplans/care-home.yaml")],
            stdout=subprocess.PIPE, stderr=errors, start_new_session=True,
        )  # fmt: skip
    stack.callback(end_process, process)
    assert process.stdout is not None
    output, deadline = b"", time.monotonic() + SIM_TIMEOUT_S
    while b"\n" not in output:
        left = deadline - time.monotonic()
        if left <= 0 or process.poll() is not None:
            raise RuntimeError(f"no pty from the simulator: {(folder / 'sim.log').read_text()}")
        if select.select([process.stdout], [], [], left)[0]:
            output += os.read(process.stdout.fileno(), 4096)
    return output.decode().split("\n", 1)[0].strip()


def start_daemon(stack: contextlib.ExitStack, folder: Path, port: str) -> subprocess.Popen[bytes]:
    env = {**os.environ, "XDG_RUNTIME_DIR": str(folder),
           "XDG_CONFIG_HOME": str(folder / "config")}  # fmt: skip
    (folder / "config").mkdir()
    with (folder / "daemon.log").open("wb") as notes:
        process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "serve", "--port", port, "--at", "dock"],
            stdin=subprocess.DEVNULL, stdout=notes, stderr=subprocess.STDOUT, env=env,
            start_new_session=True,
        )  # fmt: skip
    stack.callback(end_process, process)
    deadline = time.monotonic() + SOCKET_TIMEOUT_S
    while not socket_of(folder).exists():
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"the daemon did not listen: {(folder / 'daemon.log').read_text()}")
        time.sleep(0.1)
    return process


def socket_of(folder: Path) -> Path:
    return folder / "giraff-console" / "robot.sock"


class Listener:
    """Every Telemetry's arrival and late_ms, heard as a console that takes no controls."""

    def __init__(self, path: Path) -> None:
        self.ticks: list[tuple[float, float, float]] = []  # (heard at, late_ms, loop_hz)
        self._first = threading.Event()
        self.robot = RemoteRobot(path, "bench listener", take=False)
        self.robot.subscribe(self._hear)

    def _hear(self, event: object) -> None:  # on the client's reading thread
        if isinstance(event, Telemetry):
            self.ticks.append((time.monotonic(), event.late_ms, event.loop_hz))
            self._first.set()

    def wait_first(self) -> None:
        if not self._first.wait(FIRST_TICK_TIMEOUT_S):
            raise RuntimeError("no telemetry from the daemon")

    def between(self, start: float, end: float) -> list[tuple[float, float]]:
        """(late_ms, loop_hz) of the ticks heard from `start` to `end`."""
        return [(late, hz) for at, late, hz in self.ticks if start <= at <= end]


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(share * (len(ordered) - 1)))]


def lateness_row(name: str, ticks: list[tuple[float, float]], seconds: float) -> str:
    if not ticks:
        return f"{name:>6}: no ticks heard in {seconds:.1f} s"
    late = [value for value, _ in ticks]
    over = sum(value > LATE_MS for value in late)
    return (f"{name:>6}: {len(late)} ticks in {seconds:.1f} s ({len(late) / seconds:.1f}/s); "
            f"late_ms p50 {percentile(late, 0.5):.2f}, p99 {percentile(late, 0.99):.2f}, "
            f"max {max(late):.2f}; later than {LATE_MS:g} ms: {over}; the loop's own rate "
            f"at least {min(hz for _, hz in ticks):.1f} Hz")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--busy", type=int, default=2, metavar="N")
    parser.add_argument("--quiet-seconds", type=float, default=10.0, metavar="S")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="gsf-", dir="/tmp"))  # short: a socket's path
    load_before = os.getloadavg()
    with contextlib.ExitStack() as stack:
        port = start_board(stack, folder)
        daemon = start_daemon(stack, folder, port)
        listener = Listener(socket_of(folder))
        stack.callback(listener.robot.close)
        listener.wait_first()
        # The daemon's start is not the quiet window: the tick that connects the board
        # (its handshake and probe, 0.3 s at 115200 baud) makes the next one that late.
        time.sleep(START_SETTLE_S)
        busy = [subprocess.Popen(["python3", "-c", "while 1: pass"]) for _ in range(args.busy)]
        for loop in busy:
            stack.callback(end_process, loop, signal.SIGKILL)
        poses_before = len(true_poses(folder / "poses.txt"))
        quiet_start = time.monotonic()
        time.sleep(args.quiet_seconds)
        fuzz_start = time.monotonic()
        findings = pelt(socket_of(folder), args.count, args.seed)
        fuzz_end = time.monotonic()
        status = status_after(socket_of(folder))
        alive = daemon.poll() is None
        load_during = os.getloadavg()
    rows = true_poses(folder / "poses.txt")
    since = rows[poses_before][0] if len(rows) > poses_before else float("inf")

    print(f"socket fuzz: {findings.sent} lines, seed {args.seed}, {findings.seconds:.1f} s "
          f"({findings.sent / findings.seconds:.0f} lines/s)")  # fmt: skip
    print("  by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(findings.by_kind.items())))
    print(f"  answered {findings.answered} of {findings.sent}; consoles hung up on: "
          f"{findings.hung_up}")  # fmt: skip
    print(f"  answers with Python's own words: {len(findings.python_texts)}")
    for what, text in findings.python_texts[:10]:
        print(f"    {what}: {text[:160]}")
    print(f"  daemon alive after: {alive}; a new console's status answered: "
          f"{status is not None and status.ok}")  # fmt: skip
    print(f"  true pose travelled from the quiet window on: {travelled(rows, since):.4f} m "
          f"(pose log rows {len(rows) - poses_before})")  # fmt: skip
    print("tick lateness (Telemetry.late_ms, the listener console):")
    print(
        lateness_row("quiet", listener.between(quiet_start, fuzz_start), fuzz_start - quiet_start)
    )
    print(lateness_row("fuzz", listener.between(fuzz_start, fuzz_end), fuzz_end - fuzz_start))
    print(f"load: {args.busy} busy loops beside it; load average {load_before[0]:.2f} at the "
          f"start, {load_during[0]:.2f} at the end; {os.cpu_count()} cores")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
