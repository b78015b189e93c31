"""Benchmark: the daemon (issue 15): an attached console's CPU, and the control loop's
tick lateness with a busy screen attached, against the console that runs the loop itself.

Each setup runs its robot, then the real console in a detached tmux server of its own
(120x40, COLORTERM=truecolor), in a runtime folder (XDG_RUNTIME_DIR) of the run's own:

- "daemon": `giraff-console serve` in a process of its own, and the bare
  `giraff-console` attached to it (the map and the telemetry; the camera is the
  daemon's). The benchmark listens to the daemon as one more client
  (`RemoteRobot(..., take=False)`), keeping only each Telemetry's time, `late_ms`,
  `loop_hz` and whether a mission runs.
- "in-process" (the peer, the way before issue 15): the console with the loop, the
  board and the camera in its one process. It does not export its telemetry and its
  screen shows the loop's rate but not how late ticks are, so the benchmark starts it
  through itself (`--tap FILE -- ARGS`, hidden): the same `giraff-console` main, with a
  listener on its ControlLoop, like bench/teleop.py's, that writes the same four fields
  to a file twice a second.

The robot is either the simulator over a pty (`giraff-console sim --pty --pace` in
another process, the loop on the real clock, as with a real board), or the built-in
one (`--sim`). `serve --sim` runs its loop stepped on the simulator's virtual clock
(runtime/robot.py), whose ticks are never late by that clock: its `late_ms` is always 0 and
its `loop_hz` 20. So the benchmark also times the ticks as they arrive: "gap" is the
time between one tick's telemetry and the next's, 50 ms when the loop keeps its rate.

In each setup, `m` (once) sets the centre to the map alone; then for `--idle-seconds`
the robot stands still ("idle"), then `go kitchen` is typed into the console and, while
it drives (`go lobby` and back if it arrives), the map, the pose and the telemetry
change at every tick ("busy") for `--seconds` and at least 20 ticks a second of it.
CPU is each process's utime+stime from /proc over the window, as a share of one core;
"main" is the console's main thread (Textual's event loop: the screen), the rest its
other threads (the socket's reader, the loop in-process, the camera).

`--busy N` runs N busy loops (`python3 -c 'while 1: pass'`) beside it (default 2, as
issue 15 asks the figures under load); they, the robots and the tmux servers are ended
afterwards, whatever happens.

Usage: python bench/daemon_load.py [--seconds S] [--idle-seconds S] [--busy N]
                                    [--robot pty|sim|both] [--no-peer]
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import itertools
import os
import platform
import re
import select
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

# No giraff_console import here: with --tap this process becomes the console, whose
# signals must be blocked before numpy's and OpenCV's threads start (launch.py).
ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

PERIOD_MS = 50.0  # the control loop's 20 Hz
HZ = os.sysconf("SC_CLK_TCK")
SIM_TIMEOUT_S = 20.0
SOCKET_TIMEOUT_S = 30.0
SCREEN_TIMEOUT_S = 60.0  # a console's start-up on a loaded machine
MISSION_TIMEOUT_S = 30.0
END_TIMEOUT_S = 10.0
ROOMS = ("kitchen", "lobby")
_servers = itertools.count(1)


@dataclass(frozen=True)
class Tick:
    at: float  # time.monotonic() when heard
    late_ms: float
    loop_hz: float
    driving: bool  # a mission runs


@dataclass(frozen=True)
class Setup:
    name: str
    daemon: bool
    robot: str  # "pty": `sim --pty --pace` in a process of its own; "sim": `--sim`


@dataclass
class Window:
    setup: Setup
    phase: str
    seconds: float
    cpu: dict[str, float]  # share of one core, by process
    main: float  # the console's main thread's share
    ticks: list[Tick]
    goes: int  # `go` commands typed in the window
    ui_fps: str  # what the console's top line said at the end
    load: str  # the machine's load average over the last minute, at the end
    queued_ms: float  # the loop's process: mean wait for a CPU each time a thread ran


# -- the in-process console, tapped ----------------------------------------------------


def tapped_console(tap: Path, argv: list[str]) -> int:
    """`giraff-console ARGV` in this process, each Telemetry of its control loop written
    to `tap` as `time late_ms loop_hz driving`; the peer's only way to tell how late its
    ticks are (the screen shows the loop's rate alone)."""
    from giraff_console.robot.last_stop import SIGNALS

    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)  # as launch.main, before any thread
    from giraff_console.cli.main import main as cli_main
    from giraff_console.robot.control_loop import ControlLoop
    from giraff_console.robot.telemetry import Telemetry

    heard: collections.deque[str] = collections.deque()

    def hear(event: object) -> None:  # on the loop's thread: one append
        if isinstance(event, Telemetry):
            heard.append(f"{time.monotonic():.6f} {event.late_ms:.4f} {event.loop_hz:.1f} "
                         f"{int(event.mission is not None)}\n")  # fmt: skip

    start = ControlLoop.start

    def start_tapped(self: ControlLoop, *args: object, **kwargs: object) -> None:
        self.subscribe(hear)
        start(self, *args, **kwargs)  # type: ignore[arg-type]

    ControlLoop.start = start_tapped  # type: ignore[method-assign]
    done = threading.Event()

    def write() -> None:
        with tap.open("a") as out:
            while not done.wait(0.5):
                while heard:
                    out.write(heard.popleft())
                out.flush()

    writer = threading.Thread(target=write, name="bench-tap", daemon=True)
    writer.start()
    try:
        return cli_main(argv)
    finally:
        done.set()
        writer.join(2.0)


# -- processes -------------------------------------------------------------------------


def cpu_seconds(pid: int, tid: int | None = None) -> float:
    """utime + stime of a process (all its threads) or of one of its threads."""
    path = f"/proc/{pid}/stat" if tid is None else f"/proc/{pid}/task/{tid}/stat"
    fields = Path(path).read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / HZ  # fields 14 and 15 of stat(5)


def run_queue(pid: int) -> tuple[float, int]:
    """How long the threads of a process have waited for a CPU, in seconds, and how many
    times they have run (schedstat: the scheduler's own count)."""
    waited, runs = 0, 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError, ValueError):
            _, wait_ns, slices = (int(v) for v in (task / "schedstat").read_text().split())
            waited, runs = waited + wait_ns, runs + slices
    return waited / 1e9, runs


def end_process(process: subprocess.Popen, sig: int = signal.SIGTERM) -> None:
    """`sig`, then SIGKILL if it outlives END_TIMEOUT_S; reaped either way."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):  # ended meanwhile
            process.send_signal(sig)
        try:
            process.wait(END_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(END_TIMEOUT_S)


def start_sim_pty(stack: contextlib.ExitStack, log: Path) -> tuple[subprocess.Popen, str]:
    """`giraff-console sim --pty --pace` in the example care home's dock; its pty's path."""
    with log.open("wb") as errors:
        process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "sim", "--pty", "--pace", "--floorplan",
             str(ROOT / "giraff_console/floorplans/care-home.yaml")],
            stdout=subprocess.PIPE, stderr=errors, start_new_session=True,
        )  # fmt: skip
    stack.callback(end_process, process)
    assert process.stdout is not None
    output, deadline = b"", time.monotonic() + SIM_TIMEOUT_S
    while b"\n" not in output:
        left = deadline - time.monotonic()
        if left <= 0 or process.poll() is not None:
            raise RuntimeError(f"no pty from the simulator: {output!r} {log.read_text()[-300:]}")
        if select.select([process.stdout], [], [], left)[0]:
            output += os.read(process.stdout.fileno(), 4096)
    return process, output.decode().split("\n", 1)[0].strip()


def start_daemon(stack: contextlib.ExitStack, robot: list[str], env: dict[str, str],
                 log: Path) -> tuple[subprocess.Popen, Path]:  # fmt: skip
    """`giraff-console serve ROBOT`, once its socket is there; SIGTERM at the end."""
    with log.open("wb") as notes:
        process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "serve", *robot],
            stdin=subprocess.DEVNULL, stdout=notes, stderr=subprocess.STDOUT, env=env,
            start_new_session=True,
        )  # fmt: skip
    stack.callback(end_process, process)
    path = Path(env["XDG_RUNTIME_DIR"]) / "giraff-console" / "robot.sock"
    deadline = time.monotonic() + SOCKET_TIMEOUT_S
    while not path.exists():
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"the daemon did not listen: {log.read_text()[-500:]}")
        time.sleep(0.1)
    return process, path


class Terminal:
    """A command in a detached tmux server of its own, 120x40."""

    def __init__(self, command: list[str], env: dict[str, str]) -> None:
        self.server = f"giraff-bench-{os.getpid()}-{next(_servers)}"
        settings = " ".join(shlex.quote(f"{k}={v}") for k, v in env.items())
        self._tmux("new-session", "-d", "-x", "120", "-y", "40",
                   f"exec env {settings} {shlex.join(command)}")  # fmt: skip
        self.pid = self._python()

    def _tmux(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.server, "-f", "/dev/null", *args],
                              capture_output=True, text=True, timeout=10,
                              check=True).stdout  # fmt: skip

    def _python(self) -> int:
        """The console's process: the pane's (exec'd), else the first python under it."""
        pane = int(self._tmux("list-panes", "-F", "#{pane_pid}").split()[0])
        for _ in range(50):
            if "python" in Path(f"/proc/{pane}/cmdline").read_bytes().decode(errors="replace"):
                return pane
            for stat in Path("/proc").glob("[0-9]*/stat"):
                with contextlib.suppress(OSError, IndexError):
                    if int(stat.read_text().rsplit(")", 1)[1].split()[1]) == pane:
                        return int(stat.parent.name)
            time.sleep(0.1)
        raise RuntimeError("no python process under the tmux pane")

    def screen(self) -> str:
        return self._tmux("capture-pane", "-p")

    def keys(self, *keys: str, literal: bool = False) -> None:
        self._tmux("send-keys", *(("-l",) if literal else ()), *keys)

    def wait_for(self, text: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while text not in (screen := self.screen()):
            if time.monotonic() > deadline:
                raise RuntimeError(f"the console did not show {text!r}:\n{screen}")
            time.sleep(0.2)

    def type(self, command: str) -> None:
        """Enter, the command once the command line shows, Enter."""
        self.keys("Enter")
        self.wait_for("controller command", 10.0)
        self.keys(command, literal=True)
        time.sleep(0.2)
        self.keys("Enter")

    def close(self) -> None:
        """The tmux server goes (SIGHUP: the console stops the robot), then the console."""
        with contextlib.suppress(subprocess.SubprocessError):
            self._tmux("kill-server")
        deadline = time.monotonic() + END_TIMEOUT_S
        while Path(f"/proc/{self.pid}").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)


# -- ticks -----------------------------------------------------------------------------


class DaemonTicks:
    """Every Telemetry the daemon sends, heard as a client that takes no controls."""

    def __init__(self, path: Path) -> None:
        from giraff_console.robot.telemetry import Telemetry
        from giraff_console.service.remote import RemoteRobot

        self.ticks: list[Tick] = []

        def hear(event: object) -> None:  # on the client's reading thread: one append
            if isinstance(event, Telemetry):
                self.ticks.append(Tick(time.monotonic(), event.late_ms, event.loop_hz,
                                       event.mission is not None))  # fmt: skip

        self.robot = RemoteRobot(path, "bench", take=False)
        self.robot.subscribe(hear)

    def read(self) -> list[Tick]:
        return self.ticks

    def close(self) -> None:
        self.robot.close()


class TapTicks:
    """The ticks the tapped in-process console wrote (`tapped_console`)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.ticks: list[Tick] = []
        self._offset = 0

    def read(self) -> list[Tick]:
        with contextlib.suppress(FileNotFoundError), self.path.open("rb") as file:
            file.seek(self._offset)
            data = file.read()
            whole = data[: data.rfind(b"\n") + 1]
            self._offset += len(whole)
            for line in whole.decode().splitlines():
                at, late, hz, driving = line.split()
                self.ticks.append(Tick(float(at), float(late), float(hz), driving == "1"))
        return self.ticks

    def close(self) -> None:
        pass


# -- one setup -------------------------------------------------------------------------


def run_setup(setup: Setup, folder: Path, idle_s: float, busy_s: float) -> list[Window]:
    folder.mkdir(mode=0o700)
    env = {"XDG_RUNTIME_DIR": str(folder), "XDG_CONFIG_HOME": str(folder / "config"),
           "XDG_DATA_HOME": str(folder / "data"), "COLORTERM": "truecolor"}  # fmt: skip
    processes: dict[str, int] = {}
    with contextlib.ExitStack() as stack:
        robot = ["--sim"]
        if setup.robot == "pty":
            sim, port = start_sim_pty(stack, folder / "sim.log")
            processes["sim"] = sim.pid
            # The robot stands on its dock, and the operator says so (issue 25).
            robot = ["--port", port, "--at", "dock"]
        if setup.daemon:
            daemon, path = start_daemon(stack, robot, {**os.environ, **env},
                                        folder / "daemon.log")  # fmt: skip
            processes["daemon"] = daemon.pid
            command = [sys.executable, "-m", "giraff_console"]
        else:
            tap = folder / "ticks.txt"
            command = [sys.executable, str(Path(__file__).resolve()), "--tap", str(tap),
                       "--", *robot]  # fmt: skip
        terminal = Terminal(command, env)
        stack.callback(terminal.close)
        processes["console"] = terminal.pid
        terminal.wait_for("m/s", SCREEN_TIMEOUT_S)  # the board has answered
        feed = DaemonTicks(path) if setup.daemon else TapTicks(tap)
        stack.callback(feed.close)
        terminal.keys("m")  # attached, "both" has no camera already: this is the map alone
        time.sleep(3.0)
        windows = [measure(setup, "idle", terminal, feed, processes, idle_s, 0)]
        terminal.type(f"go {ROOMS[0]}")
        deadline = time.monotonic() + MISSION_TIMEOUT_S
        while not (feed.read() and feed.read()[-1].driving):
            if time.monotonic() > deadline:
                raise RuntimeError(f"no mission started:\n{terminal.screen()}")
            time.sleep(0.2)
        windows.append(measure(setup, "busy", terminal, feed, processes, busy_s,
                               round(busy_s * 1e3 / PERIOD_MS)))  # fmt: skip
    return windows


def measure(setup: Setup, phase: str, terminal: Terminal, feed: DaemonTicks | TapTicks,
            processes: dict[str, int], seconds: float, min_ticks: int) -> Window:  # fmt: skip
    """CPU and ticks over `seconds`, and on until `min_ticks` are heard (at most twice as
    long); while busy, a robot that has arrived is sent on to the other room."""
    console = processes["console"]
    begin = {name: cpu_seconds(pid) for name, pid in processes.items()}
    main = cpu_seconds(console, console)
    loop = processes["daemon" if setup.daemon else "console"]
    queued = run_queue(loop)
    t0 = time.monotonic()
    typed, goes = t0, 0

    def heard() -> list[Tick]:
        return [tick for tick in feed.read() if tick.at >= t0]

    while True:
        time.sleep(0.5)
        now = time.monotonic()
        if now > t0 + seconds and (len(heard()) >= min_ticks or now > t0 + 2 * seconds):
            break
        ticks = feed.read()
        if phase == "busy" and ticks and not ticks[-1].driving and now - typed > 5.0:
            goes += 1
            terminal.type(f"go {ROOMS[goes % 2]}")
            typed = time.monotonic()
    wall = time.monotonic() - t0
    cpu = {name: (cpu_seconds(pid) - begin[name]) / wall for name, pid in processes.items()}
    main = (cpu_seconds(console, console) - main) / wall
    waited, runs = run_queue(loop)
    queued_ms = (waited - queued[0]) / max(1, runs - queued[1]) * 1e3
    top = terminal.screen().splitlines()[0]
    ui = re.search(r"UI (\d+) fps", top)
    time.sleep(0.6)  # the tap's last half-second
    ticks = [tick for tick in feed.read() if t0 <= tick.at <= t0 + wall]
    fps = ui.group(1) if ui else "?"
    return Window(setup, phase, wall, cpu, main, ticks, goes, fps, loadavg().split()[0],
                  queued_ms)  # fmt: skip


# -- figures ---------------------------------------------------------------------------


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(share * (len(ordered) - 1)))]


def cpu_model() -> str:
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as cpuinfo:
        for line in cpuinfo:
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown CPU"


def loadavg() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def cpu_row(w: Window) -> str:
    share = [f"{w.cpu[name] * 100:>7.1f}" if name in w.cpu else "      -"
             for name in ("daemon", "sim")]  # fmt: skip
    total = sum(w.cpu.values()) * 100
    return (f"{w.setup.name:<30}{w.phase:<6}{w.cpu['console'] * 100:>8.1f}{w.main * 100:>7.1f}"
            f"{''.join(share)}{total:>7.1f}{w.ui_fps:>7}{w.load:>6}")  # fmt: skip


def tick_row(w: Window) -> str:
    late = [t.late_ms for t in w.ticks]
    gaps = [(b.at - a.at) * 1e3 for a, b in itertools.pairwise(w.ticks)]
    if len(late) < 2:
        return f"{w.setup.name:<30}{w.phase:<6}{len(late):>6}  (too few ticks heard)"
    hz = statistics.median(t.loop_hz for t in w.ticks)
    real = (len(w.ticks) - 1) / (w.ticks[-1].at - w.ticks[0].at)
    quantiles = "".join(f"{percentile(late, q):>7.2f}" for q in (0.5, 0.95, 0.99))
    return (f"{w.setup.name:<30}{w.phase:<6}{len(late):>6}{real:>6.1f}{hz:>6.0f}{quantiles}"
            f"{max(late):>7.2f}{percentile(gaps, 0.99):>8.1f}{max(gaps):>7.1f}"
            f"{sum(t.late_ms > 5 for t in w.ticks):>5}{w.queued_ms:>6.2f}{w.goes:>4}")  # fmt: skip


def report(windows: list[Window]) -> None:
    print("CPU, % of one core           phase  console   main daemon    sim  total UI fps  load")
    for w in windows:
        print(cpu_row(w))
    print()
    print("ticks                         phase ticks    Hz  loop    p50    p95    p99    max"
          "     gap p99   max  >5ms  rq ms goes")  # fmt: skip
    print(f"{'':<36}heard  real    Hz  {'late_ms as the loop reports it':<30}    ms apart")
    for w in windows:
        print(tick_row(w))
    for w in windows:
        if not w.setup.daemon or not w.ticks:
            continue
        late = [t.late_ms for t in w.ticks]
        if w.phase == "idle":
            share = w.cpu["console"] * 100
            print(f"idle attached console, map alone ({w.setup.name}): {share:.1f} % of a "
                  f"core (target <= 25 %): {'met' if share <= 25 else 'NOT MET'}")  # fmt: skip
        if w.phase == "busy" and w.setup.robot == "pty":
            p99 = percentile(late, 0.99)
            print(f"tick lateness, busy screen attached ({w.setup.name}): p99 {p99:.2f} ms "
                  f"over {len(late)} ticks (target <= 5 ms): "
                  f"{'met' if p99 <= 5 else 'NOT MET'}")  # fmt: skip
        if w.setup.robot == "sim" and not any(late):
            print(f"{w.setup.name}, {w.phase}: late_ms is 0 at every tick: the loop runs "
                  "stepped on the simulator's virtual clock; see the gaps")  # fmt: skip


# -- main ------------------------------------------------------------------------------


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0,
                        help="busy window, and at least 20 ticks a second of it")  # fmt: skip
    parser.add_argument("--idle-seconds", type=float, default=30.0, help="idle window")
    parser.add_argument("--busy", type=int, default=2, metavar="N",
                        help="busy loops to run beside the benchmark (default 2)")  # fmt: skip
    parser.add_argument("--robot", choices=("pty", "sim", "both"), default="both",
                        help="the simulator over a pty, the built-in one, or both")  # fmt: skip
    parser.add_argument("--no-peer", action="store_true",
                        help="only the daemon, not the in-process console")  # fmt: skip
    parser.add_argument("--tap", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("console_args", nargs="*", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.tap is not None:
        return tapped_console(args.tap, args.console_args)
    for tool in ("tmux",):
        if shutil.which(tool) is None:
            parser.error(f"{tool} is needed")
    robots = ("pty", "sim") if args.robot == "both" else (args.robot,)
    setups = [Setup(f"{'daemon' if daemon else 'in-process'}, "
                    f"{'board on a pty' if robot == 'pty' else '--sim'}", daemon, robot)
              for robot in robots for daemon in (True, False)
              if daemon or not args.no_peer]  # fmt: skip
    # SIGTERM ends the benchmark through its finally clauses, as Ctrl+C does.
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    folder = Path(tempfile.mkdtemp(prefix="giraff-bench-", dir="/tmp"))
    busy: list[subprocess.Popen] = []
    windows: list[Window] = []
    began, load_before = time.monotonic(), loadavg()
    try:
        busy = [subprocess.Popen(["python3", "-c", "while 1: pass"]) for _ in range(args.busy)]
        for n, setup in enumerate(setups):
            print(f"{setup.name}: {args.idle_seconds:g} s idle, {args.seconds:g} s busy ...",
                  file=sys.stderr, flush=True)  # fmt: skip
            windows += run_setup(setup, folder / str(n), args.idle_seconds, args.seconds)
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
          f"{load_after} at the end; {time.monotonic() - began:.0f} s")  # fmt: skip
    print()
    report(windows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
