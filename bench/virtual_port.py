"""The virtual motor port of a running daemon, used as another program would (issue 15).

Starts `giraff-console serve --sim --firmware later --virtual-port` (a board whose
imdl/imdr are reset by every read, the hard case), drives the robot 10 m by the keys
through a console attached to the daemon, and meanwhile reads `get bulk_data` on the
virtual port every 0.3 s as a driver program would, adding up its increments. At the
end it compares the program's distance with the daemon's own odometry, which polls the
same board twenty times a second; without the sharing out of increments the program
would see a few percent of the travel. Then it starts a mission and sends `set p 0.5`
from the program, which must be refused with a message.

    python bench/virtual_port.py [--metres 10] [--busy 2]
"""

from __future__ import annotations

import argparse
import math
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from giraff_console.protocol.replies import parse_reply
from giraff_console.robot.deadman import Intent
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.remote import RemoteRobot
from giraff_console.service.runtime_folder import socket_path

PROMPT = b"OK >\r\n"
# A hall with room to drive 10 m straight ahead from its start.
OPEN_FLOOR = Path(__file__).resolve().parent.parent / "tests/console/open-floor.yaml"


def ask(fd: int, line: str | None, timeout: float = 5.0) -> list[str]:
    """Send `line` to the board-like pty and return the reply lines before the prompt;
    None sends nothing and reads the greeting."""
    if line is not None:
        os.write(fd, line.encode() + b"\r")
    data = b""
    deadline = time.monotonic() + timeout
    while not data.endswith(PROMPT):
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            raise TimeoutError(f"no prompt after {line!r}: {data!r}")
        data += os.read(fd, 4096)
    return [part for part in data[: -len(PROMPT)].decode().split("\r\n") if part]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--metres", type=float, default=10.0)
    parser.add_argument("--busy", type=int, default=2, help="busy loops beside it")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="xdg-", dir="/tmp"))
    os.environ["XDG_RUNTIME_DIR"] = str(folder)
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(args.busy)]
    daemon = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "serve", "--sim", "--firmware", "later",
         "--virtual-port", "--floorplan", str(OPEN_FLOOR)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    try:
        assert daemon.stdout is not None
        if not select.select([daemon.stdout], [], [], 20)[0]:
            raise TimeoutError("the daemon printed no virtual port")
        pty = daemon.stdout.readline().strip()
        deadline = time.monotonic() + 20
        while not socket_path().exists():
            if time.monotonic() > deadline:
                raise TimeoutError("no socket")
            time.sleep(0.1)
        return measure(pty, args.metres)
    finally:
        daemon.terminate()
        try:
            daemon.wait(10)
        except subprocess.TimeoutExpired:
            daemon.kill()
        for process in busy:
            process.kill()
        shutil.rmtree(folder, ignore_errors=True)


def measure(pty: str, metres: float) -> int:
    fd = os.open(pty, os.O_RDWR | os.O_NOCTTY)
    robot = RemoteRobot(socket_path(), "bench", take=True)
    poses: list[tuple[float, float]] = []
    ended: list[MissionChanged] = []

    def heard(event: object) -> None:
        if isinstance(event, Telemetry):
            poses.append((event.pose.x, event.pose.y))
        elif isinstance(event, MissionChanged) and not event.running:
            ended.append(event)

    robot.subscribe(heard)
    try:
        ask(fd, None)  # the greeting, as a board gives it when its port is opened
        time.sleep(1.0)  # the daemon's first polls
        ask(fd, "get bulk_data")  # what came before the run is not the program's
        start = poses[-1]
        program = reads = 0
        next_read = time.monotonic()
        # At 0.4 m/s, with room to spare on a loaded machine.
        deadline = time.monotonic() + metres / 0.4 * 3 + 10
        refusals: list[str] = []
        while math.dist(poses[-1], start) < metres:
            if time.monotonic() > deadline:
                raise TimeoutError(f"only {math.dist(poses[-1], start):.2f} m driven; "
                                   f"{refusals[-1:]}")  # fmt: skip
            robot.post(
                c.Press(Intent.FORWARD),
                lambda reply: None if reply.ok else refusals.append(reply.text),
            )
            if time.monotonic() >= next_read:
                value = parse_reply(ask(fd, "get bulk_data")).value
                assert isinstance(value, dict)
                program += (value["imdl"] + value["imdr"]) / 2
                reads += 1
                next_read += 0.3
            time.sleep(0.03)
        robot.execute(c.Halt())
        time.sleep(2.0)  # to rest
        value = parse_reply(ask(fd, "get bulk_data")).value
        assert isinstance(value, dict)
        program += (value["imdl"] + value["imdr"]) / 2
        daemon = math.dist(poses[-1], start)
        print(f"driven by the keys: the daemon's odometry {daemon:.4f} m; the program's "
              f"{program:.4f} m from {reads + 1} reads; difference "
              f"{abs(daemon - program) * 100:.2f} cm")  # fmt: skip
        reply = robot.execute(c.Go("floor"))
        time.sleep(1.0)
        refused = ask(fd, "set p 0.5")
        print(f"go floor: {reply.text[:60]}...; the program's `set p 0.5` meanwhile: "
              f"{refused}")  # fmt: skip
        robot.execute(c.Halt())
        ok = abs(daemon - program) <= 0.01 and any("refused" in line for line in refused)
        print("PASS" if ok else "FAIL")
        return 0 if ok else 1
    finally:
        robot.close()
        os.close(fd)


if __name__ == "__main__":
    sys.exit(main())
