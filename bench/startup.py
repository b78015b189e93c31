"""Benchmark: what starting the program costs (issue 26, item 6: "Imports are paid only
where used").

The figure is CPU time (user + system, every thread) of one process, which other work on
the machine stretches far less than wall time; wall time beside it. Each case runs
--runs times, interleaved round by round so that other load falls on all alike, and the
median is printed:
- `giraff-console --version`, `--help`, and `plan dock kitchen` (a command that reads a
  floor plan and plans on it), each to its end, from the child's rusage;
- the console's first screen: `giraff-console --sim` in a pseudo-terminal of 120x40
  (TERM=xterm-256color), until its first full frame is on the terminal (the top bar's
  SIMULATOR badge and the footer's Quit both drawn). Then the process is stopped
  (SIGSTOP, so that nothing more is counted), killed, and its rusage read;
- beside it, a minimal Textual app (a Static and a Footer, below) measured the same
  way: the floor any Textual screen pays.

Every process runs with its own HOME and XDG folders in a temporary folder, so that no
daemon is found, no settings file is read and nothing of the user's is written. Python
may write its bytecode (PYTHONDONTWRITEBYTECODE is dropped), and a first round, not
counted, writes it: an installed package has its bytecode, and compiling the sources
again at every start would be counted as starting. Every wait has a timeout, and every
process is killed at the end whatever happens.

With --busy N, N busy loops (`python3 -c 'while 1: pass'`) run beside the
measurements, as other work on a shared machine would, and are killed afterwards.

Usage: python bench/startup.py [--runs 5] [--busy 0] [--only version,help,plan,screen,textual]
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import os
import platform
import select
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import termios
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

# The terminal every screen is drawn on.
COLUMNS, ROWS = 120, 40
# Seconds a case may take before it counts as failed (a loaded 2-core machine included).
TIMEOUT_S = 60.0

# The floor: what any Textual screen costs, with the console's Footer.
MINIMAL_APP = """
from textual.app import App, ComposeResult
from textual.widgets import Footer, Static


class Minimal(App):
    BINDINGS = [("q", "quit", "Quit")]

    def compose(self) -> ComposeResult:
        yield Static("SIMULATOR")
        yield Footer()


Minimal().run()
"""


@dataclass(frozen=True)
class Case:
    """One way of starting a process: its command, and for a screen, the words whose
    appearance on the terminal says the first frame is drawn."""

    name: str
    argv: list[str]
    screen_words: tuple[bytes, ...] = ()


@dataclass(frozen=True)
class Measured:
    cpu_s: float
    wall_s: float


def program() -> str:
    """The `giraff-console` installed beside this Python (the venv's), else on PATH."""
    beside = Path(sys.executable).with_name("giraff-console")
    found = str(beside) if beside.exists() else shutil.which("giraff-console")
    if found is None:
        sys.exit("bench/startup.py: giraff-console is not installed (pip install -e .)")
    return found


def cases() -> list[Case]:
    console = program()
    words = (b"SIMULATOR", b"Quit")
    return [
        Case("version", [console, "--version"]),
        Case("help", [console, "--help"]),
        Case("plan", [console, "plan", "dock", "kitchen"]),
        Case("screen", [console, "--sim"], words),
        Case("textual", [sys.executable, "-c", MINIMAL_APP], words),
    ]


def environment(home: Path) -> dict[str, str]:
    env = dict(os.environ, HOME=str(home), TERM="xterm-256color",
               COLUMNS=str(COLUMNS), LINES=str(ROWS))  # fmt: skip
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    for name in ("CONFIG", "DATA", "STATE", "CACHE", "RUNTIME"):
        folder = home / name.lower()
        folder.mkdir(mode=0o700, exist_ok=True)
        env[f"XDG_{name}_HOME" if name != "RUNTIME" else "XDG_RUNTIME_DIR"] = str(folder)
    return env


def measure_command(case: Case, env: dict[str, str]) -> Measured:
    """A command run to its end: its CPU from wait4's rusage."""
    started = time.monotonic()
    process = subprocess.Popen(case.argv, env=env, stdin=subprocess.DEVNULL,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        usage = wait_rusage(process, TIMEOUT_S)
    finally:
        kill(process)
    if usage is None:
        raise RuntimeError(f"{case.name}: no end within {TIMEOUT_S:g} s")
    return Measured(usage.ru_utime + usage.ru_stime, time.monotonic() - started)


def measure_screen(case: Case, env: dict[str, str]) -> Measured:
    """A screen in a pseudo-terminal, until its first full frame: stopped there, then its
    CPU from wait4's rusage."""
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLUMNS, 0, 0))
    started = time.monotonic()
    try:
        process = subprocess.Popen(case.argv, env=env, stdin=slave, stdout=slave, stderr=slave,
                                   start_new_session=True)  # fmt: skip
    finally:
        os.close(slave)
    try:
        drawn = wait_for_words(master, case.screen_words, started + TIMEOUT_S)
        wall = time.monotonic() - started
        # Frozen at once, every thread: the CPU counted is the first frame's.
        with contextlib.suppress(ProcessLookupError):
            os.kill(process.pid, signal.SIGSTOP)
        if not drawn:
            raise RuntimeError(f"{case.name}: no first frame within {TIMEOUT_S:g} s")
        os.kill(process.pid, signal.SIGKILL)
        usage = wait_rusage(process, 10.0)
        if usage is None:
            raise RuntimeError(f"{case.name}: not ended by SIGKILL")
        return Measured(usage.ru_utime + usage.ru_stime, wall)
    finally:
        kill(process)
        os.close(master)


def wait_for_words(master: int, words: tuple[bytes, ...], deadline: float) -> bool:
    """Read the terminal until every one of `words` has been written to it."""
    seen = b""
    while time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], min(0.5, deadline - time.monotonic()))
        if not ready:
            continue
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the child has gone: EIO
            return False
        if not chunk:
            return False
        seen += chunk
        if all(word in seen for word in words):
            return True
    return False


def wait_rusage(process: subprocess.Popen[bytes], timeout: float) -> os.struct_rusage | None:
    """The ended process's resource use (reaped here), or None if it has not ended within
    `timeout`."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid == process.pid:
            process.returncode = os.waitstatus_to_exitcode(status)
            return usage
        time.sleep(0.005)
    return None


def kill(process: subprocess.Popen[bytes]) -> None:
    """Ended whatever happens: killed if still there, and reaped."""
    if process.returncode is None:
        with contextlib.suppress(ProcessLookupError):
            os.kill(process.pid, signal.SIGKILL)
        with contextlib.suppress(ChildProcessError):
            process.wait(10.0)


@contextlib.contextmanager
def busy_loops(count: int) -> Iterator[None]:
    loops = [subprocess.Popen(["python3", "-c", "while 1: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait(10.0)


def machine() -> str:
    model = "unknown CPU"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5, help="runs of each case (default: 5)")
    parser.add_argument("--busy", type=int, default=0, metavar="N",
                        help="busy loops to run beside (default: 0)")  # fmt: skip
    parser.add_argument("--only", metavar="A,B", help="the cases to run (default: all)")
    args = parser.parse_args()
    chosen = cases()
    if args.only:
        wanted = args.only.split(",")
        chosen = [case for case in chosen if case.name in wanted]
    results: dict[str, list[Measured]] = {case.name: [] for case in chosen}
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="giraff-startup-") as home, busy_loops(args.busy):
        env = environment(Path(home))
        for round_number in range(args.runs + 1):
            for case in chosen:
                measure = measure_screen if case.screen_words else measure_command
                measured = measure(case, env)
                if round_number > 0:  # the first writes the bytecode
                    results[case.name].append(measured)
        load_after = os.getloadavg()[0]
    print(f"{machine()}; {args.busy} busy loops beside; load average {load_before:.2f} "
          f"before, {load_after:.2f} after; medians of {args.runs}")  # fmt: skip
    print(f"{'case':10s} {'CPU s':>7s} {'min':>7s} {'max':>7s} {'wall s':>7s}")
    for name, runs in results.items():
        cpu = [run.cpu_s for run in runs]
        wall = statistics.median(run.wall_s for run in runs)
        print(f"{name:10s} {statistics.median(cpu):7.3f} {min(cpu):7.3f} {max(cpu):7.3f} "
              f"{wall:7.3f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
