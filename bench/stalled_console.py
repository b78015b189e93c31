"""Benchmark: a console that stops reading holds up neither the control loop nor the
other consoles (issue 26).

A daemon (`giraff-console serve --sim`) serves the camera to two consoles. The steady
one attaches as a console does (service/remote.py), asks for the camera's frames and
reads everything; the stalled one asks for them too, then reads nothing, as a console
whose terminal has stopped being read (a frozen SSH session) would. First `--baseline`
seconds with the steady console alone (the peer to compare with), then `--stall`
seconds with the stalled one beside it. Measured from the steady console: the frames
it gets a second, and the control loop's lateness at each tick (Telemetry.late_ms: how
late the tick ran, p50/p99/max); and whether the daemon hung up on the stalled one.

`--busy N` runs N busy loops beside it (`python3 -c 'while 1: pass'`), ended afterwards
whatever happens, as is the daemon.

Usage: python bench/stalled_console.py [--baseline S] [--stall S] [--busy N]
"""

from __future__ import annotations

import argparse
import os
import platform
import queue
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.remote import RemoteRobot
from giraff_console.service.transport import Connection, connect

START_TIMEOUT_S = 60.0
END_TIMEOUT_S = 10.0


@dataclass
class Phase:
    name: str
    seconds: float
    frames: int
    late_ms: list[float]

    def row(self) -> str:
        late = sorted(self.late_ms) or [float("nan")]
        p99 = late[min(len(late) - 1, round(0.99 * (len(late) - 1)))]
        return (f"{self.name:<28} {self.frames / self.seconds:>6.1f} fps   "
                f"{statistics.median(late):>6.2f} {p99:>6.2f} {late[-1]:>7.2f} ms   "
                f"({len(late)} ticks)")  # fmt: skip


def start_daemon(runtime: Path) -> subprocess.Popen[bytes]:
    env = dict(os.environ, XDG_RUNTIME_DIR=str(runtime), XDG_CONFIG_HOME=str(runtime / "cfg"))
    daemon = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "serve", "--sim"], env=env,
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    socket = runtime / "giraff-console" / "robot.sock"
    deadline = time.monotonic() + START_TIMEOUT_S
    while not socket.exists():
        if daemon.poll() is not None or time.monotonic() > deadline:
            raise SystemExit("the daemon did not start")
        time.sleep(0.1)
    time.sleep(2.0)  # its first ticks and frames
    return daemon


def measure(heard: queue.Queue[object], name: str, seconds: float) -> Phase:
    phase = Phase(name, seconds, 0, [])
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        try:
            event = heard.get(timeout=left)
        except queue.Empty:
            break
        if isinstance(event, SharedFrame):
            phase.frames += 1
        elif isinstance(event, Telemetry):
            phase.late_ms.append(event.late_ms)
    return phase


def stalled(socket: Path) -> Connection:
    """A console that asks for the frames, then never reads again."""
    connection = connect(socket)
    connection.send(Hello("stalled", False))
    connection.send(Asked(1, c.View(on=True)))
    return connection


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", type=float, default=10.0)
    parser.add_argument("--stall", type=float, default=30.0)
    parser.add_argument("--busy", type=int, default=0)
    args = parser.parse_args()
    runtime = Path(tempfile.mkdtemp(prefix="gs-", dir="/tmp"))
    with ExitStack() as stack:
        stack.callback(shutil.rmtree, runtime, True)
        busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"])
                for _ in range(args.busy)]  # fmt: skip
        for loop in busy:
            stack.callback(loop.kill)
        daemon = start_daemon(runtime)

        def end_daemon() -> None:
            daemon.terminate()
            try:
                daemon.wait(END_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                daemon.kill()

        stack.callback(end_daemon)
        socket = runtime / "giraff-console" / "robot.sock"
        steady = RemoteRobot(socket, "steady", take=True)
        stack.callback(steady.close)
        heard: queue.Queue[object] = queue.Queue()
        steady.subscribe(heard.put)
        assert steady.execute(c.View(on=True)).ok
        measure(heard, "settling", 2.0)
        before = measure(heard, "steady console alone", args.baseline)
        frozen = stalled(socket)
        stack.callback(frozen.close)
        during = measure(heard, f"with one stalled {args.stall:g} s", args.stall)
        hung_up = False
        try:
            frozen.send(Asked(2, c.Heartbeat()))
            deadline = time.monotonic() + 2.0
            while time.monotonic() < deadline:
                frozen.receive(0.5)  # what queued up for it, if it is still attached
        except Exception:
            hung_up = True
        print(
            f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
            f"load average {os.getloadavg()[0]:.1f}; {args.busy} busy loops beside it"
        )
        print(f"{'':<28} {'frames':>10}   {'tick lateness p50 p99 max':>26}")
        print(before.row())
        print(during.row())
        print(
            f"the stalled console: {'hung up on by the daemon' if hung_up else 'still attached'}; "
            f"the daemon {'still runs' if daemon.poll() is None else 'ended'}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
