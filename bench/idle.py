"""Benchmark: what an idle console and an idle daemon cost (issue 26, "Light"), beside a
minimal Textual app measured in the same run.

Each program runs in a pseudo-terminal of its own, 120x40, TERM=xterm-256color and
COLORTERM=truecolor, whose output the benchmark reads and throws away as a terminal
would draw it; each in a runtime folder (XDG_RUNTIME_DIR) and settings folders of the
run's own, so that nothing attaches to, or collides with, a daemon or settings of
someone else's. Nothing is typed but the layout key; the robot stands still throughout.

- "minimal Textual app": a Static and a Footer (`--minimal-app`, this script itself):
  what Textual costs doing nothing, the floor under any console.
- "console --sim": `giraff-console --sim`, the robot, its control loop, the simulated
  camera and the screen in one process, in each layout of the centre in turn: as it
  starts (the camera and the map), then `m` (the map alone), then `m` (the camera alone).
- "daemon serve --sim": `giraff-console serve --sim`, with no console attached: its
  control loop, the simulated camera as the localisation's eye; ended with SIGTERM.
- "console attached": the bare `giraff-console` attached to that daemon, showing the
  daemon's camera as it shares it, then `m` pressed
  once (the map alone); the daemon's share beside it, with one client to feed.

For each, after `--settle` seconds, CPU is utime+stime from /proc over `--seconds` of
wall time, as a share of one core: the whole process (every thread), and its main
thread alone (Textual's event loop: the screen). Also the CPU time of
`giraff-console --version` (start-up: imports).

`--busy N` runs N busy loops (`python3 -c 'while 1: pass'`) beside it (default 0); they,
and every program started, are ended afterwards, whatever happens.

Usage: python bench/idle.py [--settle S] [--seconds S] [--busy N] [--only NAME,...]
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import os
import platform
import resource
import select
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

# The same waits, and the same words for the machine, as the daemon's benchmark.
from bench.daemon_load import cpu_model, end_process, loadavg  # noqa: E402

HZ = os.sysconf("SC_CLK_TCK")
COLUMNS, ROWS = 120, 40
START_TIMEOUT_S = 60.0  # a console's start-up on a loaded machine
SOCKET_TIMEOUT_S = 30.0
SETUPS = ("minimal", "console", "daemon", "attached")


def minimal_app() -> int:
    """The peer: a Textual app with a Static and a Footer, doing nothing."""
    from textual.app import App, ComposeResult
    from textual.widgets import Footer, Static

    class Minimal(App[None]):
        BINDINGS = [("q", "quit", "Quit")]

        def compose(self) -> ComposeResult:
            yield Static("minimal Textual app: idle")
            yield Footer()

    Minimal().run()
    return 0


# -- processes -------------------------------------------------------------------------


def cpu_seconds(pid: int, tid: int | None = None) -> float:
    """utime + stime of a process (all its threads) or of one of its threads."""
    path = f"/proc/{pid}/stat" if tid is None else f"/proc/{pid}/task/{tid}/stat"
    fields = Path(path).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / HZ  # fields 14 and 15 of stat(5)


class Terminal:
    """A command on a pseudo-terminal of COLUMNS x ROWS, its output read and dropped by a
    thread of the benchmark's (keeping the last few kilobytes, to wait for a word)."""

    def __init__(self, command: list[str], env: dict[str, str]) -> None:
        master, slave = os.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLUMNS, 0, 0))
        self.master = master
        self._tail = b""
        self._lock = threading.Lock()
        self._closed = threading.Event()
        # Standard error too: Textual draws the screen on it.
        self.process = subprocess.Popen(
            command, stdin=slave, stdout=slave, stderr=slave, env=env, start_new_session=True
        )
        os.close(slave)
        self.pid = self.process.pid
        self._reader = threading.Thread(target=self._read, name="pty-reader", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while not self._closed.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.2)
            if not ready:
                continue
            try:
                data = os.read(self.master, 65536)
            except OSError:  # the program has gone: the pty's other end is closed
                return
            if not data:
                return
            with self._lock:
                self._tail = (self._tail + data)[-16384:]

    def wait_for(self, word: bytes, timeout: float) -> None:
        """Until `word` has been written to the screen; RuntimeError after `timeout`."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                if word in self._tail:
                    return
            if self.process.poll() is not None or time.monotonic() > deadline:
                with self._lock:
                    screen = self._tail[-2000:].decode(errors="replace")
                raise RuntimeError(f"{word!r} never showed ({self.process.returncode}): {screen}")
            time.sleep(0.1)

    def key(self, key: bytes) -> None:
        os.write(self.master, key)

    def close(self) -> None:
        """SIGTERM (the console stops the robot), SIGKILL if it lingers; the pty closed."""
        try:
            end_process(self.process)
        finally:
            self._closed.set()
            self._reader.join(2.0)
            with contextlib.suppress(OSError):
                os.close(self.master)


def start_daemon(env: dict[str, str], log: Path) -> subprocess.Popen:
    """`giraff-console serve --sim`, once its socket is there."""
    with log.open("wb") as notes:
        process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "serve", "--sim"],
            stdin=subprocess.DEVNULL, stdout=notes, stderr=subprocess.STDOUT, env=env,
            start_new_session=True,
        )  # fmt: skip
    path = Path(env["XDG_RUNTIME_DIR"]) / "giraff-console" / "robot.sock"
    deadline = time.monotonic() + SOCKET_TIMEOUT_S
    while not path.exists():
        if process.poll() is not None or time.monotonic() > deadline:
            end_process(process)
            raise RuntimeError(f"the daemon did not listen: {log.read_text()[-500:]}")
        time.sleep(0.1)
    return process


# -- measuring -------------------------------------------------------------------------


@dataclass
class Row:
    name: str
    cpu: float  # share of one core, the whole process
    main: float | None  # its main thread's share; None where it means nothing
    beside: str  # another process's share, measured in the same window
    load: str  # the 1-minute load average at the end


def measure(name: str, pid: int, seconds: float, main: bool = True,
            other: tuple[str, int] | None = None) -> Row:  # fmt: skip
    """The share of one core `pid` (and `other`) used over `seconds` of wall time."""
    begin = cpu_seconds(pid)
    begin_main = cpu_seconds(pid, pid)
    begin_other = cpu_seconds(other[1]) if other else 0.0
    t0 = time.monotonic()
    time.sleep(seconds)
    wall = time.monotonic() - t0
    cpu = (cpu_seconds(pid) - begin) / wall
    main_share = (cpu_seconds(pid, pid) - begin_main) / wall if main else None
    beside = ""
    if other is not None:
        beside = f"{other[0]} {100 * (cpu_seconds(other[1]) - begin_other) / wall:.1f} %"
    row = Row(name, cpu, main_share, beside, loadavg().split()[0])
    print(f"  {name}: {100 * cpu:.1f} % of a core", file=sys.stderr, flush=True)
    return row


def startup_cpu(env: dict[str, str]) -> float:
    """CPU seconds (user + system) of `giraff-console --version`, all of it imports."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "giraff_console", "--version"], env=env,
                   capture_output=True, timeout=60, check=True)  # fmt: skip
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(only: set[str], folder: Path, settle: float, seconds: float) -> list[Row]:
    env = {
        **os.environ, "TERM": "xterm-256color", "COLORTERM": "truecolor",
        "XDG_RUNTIME_DIR": str(folder / "run"), "XDG_CONFIG_HOME": str(folder / "config"),
        "XDG_DATA_HOME": str(folder / "data"), "XDG_STATE_HOME": str(folder / "state"),
        "COLUMNS": str(COLUMNS), "LINES": str(ROWS),
    }  # fmt: skip
    (folder / "run").mkdir(mode=0o700)
    console = [sys.executable, "-m", "giraff_console"]
    rows: list[Row] = []
    with contextlib.ExitStack() as stack:

        def terminal(command: list[str]) -> Terminal:
            shown = Terminal(command, env)
            stack.callback(shown.close)
            return shown

        def settled(then: Callable[[], None] | None = None) -> None:
            if then is not None:
                then()
            time.sleep(settle)

        if "minimal" in only:
            app = terminal([sys.executable, str(Path(__file__).resolve()), "--minimal-app"])
            app.wait_for(b"idle", START_TIMEOUT_S)
            settled()
            rows.append(measure("minimal Textual app", app.pid, seconds))
            app.close()
        if "console" in only:
            sim = terminal([*console, "--sim"])
            sim.wait_for(b"keys -", START_TIMEOUT_S)
            settled()
            rows.append(measure("console --sim, camera and map", sim.pid, seconds))
            settled(lambda: sim.key(b"m"))
            rows.append(measure("console --sim, map alone", sim.pid, seconds))
            settled(lambda: sim.key(b"m"))
            rows.append(measure("console --sim, camera alone", sim.pid, seconds))
            sim.close()
        if "daemon" in only or "attached" in only:
            daemon = start_daemon(env, folder / "daemon.log")
            stack.callback(end_process, daemon)
            settled()
            if "daemon" in only:
                rows.append(measure("daemon serve --sim", daemon.pid, seconds, main=False))
            if "attached" in only:
                attached = terminal(console)
                # The daemon's camera, once its frames come: drawn 10 times a second, the
                # main view's "keys -" soon leaves the tail of what was written.
                attached.wait_for(b"cam 800x600", START_TIMEOUT_S)
                settled()
                # The daemon's camera, shared with it (camera/shared_frame.py).
                rows.append(measure("console attached, camera and map", attached.pid,
                                    seconds, other=("daemon", daemon.pid)))  # fmt: skip
                settled(lambda: attached.key(b"m"))
                rows.append(measure("console attached, map alone", attached.pid, seconds,
                                    other=("daemon", daemon.pid)))  # fmt: skip
                attached.close()
            end_process(daemon)
    return rows


# -- figures ---------------------------------------------------------------------------


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--settle", type=float, default=5.0, help="seconds before measuring")
    parser.add_argument("--seconds", type=float, default=20.0, help="seconds measured")
    parser.add_argument("--busy", type=int, default=0, metavar="N",
                        help="busy loops to run beside the benchmark (default 0)")  # fmt: skip
    parser.add_argument("--only", default=",".join(SETUPS),
                        help=f"which of {','.join(SETUPS)} (default: all)")  # fmt: skip
    parser.add_argument("--minimal-app", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.minimal_app:
        return minimal_app()
    only = set(args.only.split(","))
    if not only <= set(SETUPS):
        parser.error(f"--only: one or more of {', '.join(SETUPS)}")
    # SIGTERM ends the benchmark through its finally clauses, as Ctrl+C does.
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    folder = Path(tempfile.mkdtemp(prefix="giraff-idle-", dir="/tmp"))
    busy: list[subprocess.Popen] = []
    began, load_before = time.monotonic(), loadavg()
    try:
        busy = [subprocess.Popen(["python3", "-c", "while 1: pass"]) for _ in range(args.busy)]
        version_cpu = startup_cpu({**os.environ, "XDG_CONFIG_HOME": str(folder / "config")})
        rows = run(only, folder, args.settle, args.seconds)
        load_after = loadavg()
    finally:
        for loop in busy:
            end_process(loop, signal.SIGKILL)
        shutil.rmtree(folder, ignore_errors=True)
    import textual

    import giraff_console

    print(f"giraff-console {giraff_console.__version__}, Textual {textual.__version__}, "
          f"Python {platform.python_version()}, {platform.machine()}, {cpu_model()}, "
          f"nproc {os.cpu_count()}, Linux {platform.release()}")  # fmt: skip
    print(f"load: {args.busy} busy loops beside it; load average {load_before} at the start, "
          f"{load_after} at the end; {time.monotonic() - began:.0f} s; each window "
          f"{args.seconds:g} s after {args.settle:g} s to settle")  # fmt: skip
    print()
    print(f"{'CPU, % of one core':<34}{'process':>8}{'main':>7}  {'load':>5}  beside")
    for row in rows:
        main_share = f"{100 * row.main:>7.1f}" if row.main is not None else f"{'-':>7}"
        print(f"{row.name:<34}{100 * row.cpu:>8.1f}{main_share}  {row.load:>5}  {row.beside}")
    print(f"giraff-console --version: {version_cpu:.2f} s of CPU (user + system)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
