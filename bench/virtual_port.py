"""Benchmark: programs written for real Giraffs, on a board and through the daemon's
virtual port (issue 27).

The programs are the two raw clients of tests/drivers/clients.py, modelled on
wire-facts' description of the deployed ROS 1 and ROS 2 drivers ("What the deployed
drivers do"): the ROS 2-like one loops at 40 Hz sending its idle stop idiom and reading
`bulk_data`; the ROS 1-like one loops at 30 Hz reading `bulk_data`, `enc0`, `enc1`, `h`
and `charger_data`. For each:

- **direct**: on `giraff-console sim --pty --pace --firmware later` (a board whose
  every byte takes as long as on a 115200-baud line), the client starts and polls for
  `--seconds`: the latency of its replies (command written to prompt read) and the
  rate of its loop. This is the peer: what the program sees on a board of its own.
- **through the port**: on `giraff-console serve --sim --firmware later
  --virtual-port`, the client starts on the port and polls on a thread of its own while
  the daemon runs `--missions` `go` missions between the dock and room-101 (8.5 m each),
  asked by a console attached as an operator's is. Counted: the missions that arrived,
  the daemon's odometry alarms (its notes of wheel readings that disagree), the
  missions ended by the program, the error replies the client got (at its start-up
  and after), and the same latency and loop rate.

With `--kills N`, instead: the robot built in this process as the daemon builds it (the
composition root, with its virtual port), and N times a ROS 2-like client in a process
of its own drives at the console's top speed (0.4 m/s, forwards and backwards in turn)
and is killed (SIGKILL) after 1 to 2 s: how far the robot went after the kill, by the
simulator's true pose, against the runaway limit of 0.3 m (design.md).

`--busy N` runs N busy loops beside it all (`python3 -c 'while 1: pass'`). Every wait has
a timeout; every process started is ended whatever happens.

Usage: python bench/virtual_port.py [--clients ros2,ros1] [--missions 10] [--seconds 20] [--busy 2]
       python bench/virtual_port.py --kills 30 [--busy 2]
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import select
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the clients live with the tests

from giraff_console.robot.loop_events import MissionChanged, Note  # noqa: E402
from giraff_console.runtime.options import RobotOptions  # noqa: E402
from giraff_console.runtime.robot import Robot  # noqa: E402
from giraff_console.service import commands as c  # noqa: E402
from giraff_console.service.remote import RemoteRobot  # noqa: E402
from giraff_console.service.runtime_folder import socket_path  # noqa: E402
from giraff_console.settings import Settings  # noqa: E402
from tests.drivers.clients import Ros1LikeClient, Ros2LikeClient  # noqa: E402
from tests.drivers.kill import driving_client, went_on  # noqa: E402
from tests.drivers.wire import RawPort  # noqa: E402

WHEEL_BASE_M = 0.499  # the simulator's, by default
START_TIMEOUT_S = 60.0
MISSION_TIMEOUT_S = 120.0
ROOMS = ("room-101", "dock")
# What the daemon's odometry check says when no wheel reading agrees with cdis
# (robot/odometer_check.py), or its feed when a reading jumps.
ALARMS = ("no wheel reading agrees", "odometry")
BY_THE_PROGRAM = "virtual port"


@dataclass
class Run:
    """One client's figures in one setting."""

    name: str
    seconds: float
    traffic: list[float] = field(default_factory=list)  # latencies, s
    loops: list[float] = field(default_factory=list)  # loop periods, s
    errors: list[tuple[str, str]] = field(default_factory=list)
    missions: int = 0
    arrived: int = 0
    alarms: list[str] = field(default_factory=list)
    ended_by_program: int = 0

    def row(self) -> str:
        late = sorted(self.traffic) or [float("nan")]
        p99 = late[min(len(late) - 1, round(0.99 * (len(late) - 1)))]
        rate = 1 / statistics.median(self.loops) if self.loops else float("nan")
        missions = ""
        if self.missions:
            missions = (f"   {self.arrived}/{self.missions} arrived, {len(self.alarms)} alarms, "
                        f"{self.ended_by_program} ended by the program")  # fmt: skip
        return (f"{self.name:<34} {statistics.median(late) * 1000:6.1f} {p99 * 1000:6.1f} "
                f"{late[-1] * 1000:7.1f} ms  {rate:5.1f} Hz  {len(self.errors):3d} errors"
                f"{missions}")  # fmt: skip


def client_for(kind: str, port: RawPort) -> Ros1LikeClient | Ros2LikeClient:
    if kind == "ros2":
        return Ros2LikeClient(port, WHEEL_BASE_M)
    return Ros1LikeClient(port, WHEEL_BASE_M)


@contextmanager
def started(command: list[str], env: dict[str, str]) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               stdin=subprocess.DEVNULL, text=True, env=env)  # fmt: skip
    try:
        yield process
    finally:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(10)


def first_line(process: subprocess.Popen[str], what: str) -> str:
    assert process.stdout is not None
    if not select.select([process.stdout], [], [], START_TIMEOUT_S)[0]:
        raise TimeoutError(f"{what} printed nothing within {START_TIMEOUT_S} s")
    line = process.stdout.readline().strip()
    if not line:
        raise RuntimeError(f"{what} ended before printing its port")
    return line


def direct(kind: str, seconds: float, env: dict[str, str]) -> Run:
    command = [sys.executable, "-m", "giraff_console", "sim", "--pty", "--pace",
               "--firmware", "later"]  # fmt: skip
    with started(command, env) as simulator:
        port = RawPort.open(first_line(simulator, "the simulator"))
        try:
            client = client_for(kind, port)
            client.start()
            client.traffic.latencies.clear()
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                client.idle(1)
        finally:
            port.close()
    return Run(f"{kind}, direct (a 115200-baud line)", seconds, client.traffic.latencies,
               client.traffic.loops, client.traffic.errors)  # fmt: skip


def through_the_port(kind: str, missions: int, env: dict[str, str]) -> Run:
    command = [sys.executable, "-m", "giraff_console", "serve", "--sim", "--firmware", "later",
               "--virtual-port"]  # fmt: skip
    with started(command, env) as daemon, ExitStack() as stack:
        path = first_line(daemon, "the daemon")
        deadline = time.monotonic() + START_TIMEOUT_S
        while not socket_path().exists():
            if time.monotonic() > deadline:
                raise TimeoutError("the daemon's socket never came")
            time.sleep(0.1)
        robot = RemoteRobot(socket_path(), "bench", take=True)
        stack.callback(robot.close)
        ends: list[MissionChanged] = []
        alarms: list[str] = []

        def heard(event: object) -> None:
            if isinstance(event, MissionChanged) and not event.running:
                ends.append(event)
            elif isinstance(event, Note) and any(word in event.text for word in ALARMS):
                alarms.append(event.text)

        robot.subscribe(heard)
        port = RawPort.open(path)
        stack.callback(port.close)
        client = client_for(kind, port)
        client.start()
        done = threading.Event()
        failed: list[BaseException] = []

        def poll() -> None:
            try:
                while not done.is_set():
                    client.idle(1)
            except BaseException as error:  # told below, not lost on a thread
                failed.append(error)

        poller = threading.Thread(target=poll, name="client", daemon=True)
        started_at = time.monotonic()
        poller.start()
        run = Run(f"{kind}, through the port, daemon on go", 0.0)
        try:
            for number in range(missions):
                room = ROOMS[number % len(ROOMS)]
                asked = len(ends)
                replies: list[object] = []
                robot.post(c.Go(room), replies.append)
                deadline = time.monotonic() + MISSION_TIMEOUT_S
                while len(ends) == asked and not failed:
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"go {room} did not end within {MISSION_TIMEOUT_S} s")
                    time.sleep(0.05)
                if failed:
                    raise RuntimeError(f"the client failed: {failed[0]!r}")
                end = ends[-1].end
                run.missions += 1
                run.arrived += end is not None and end.outcome.arrived
                run.ended_by_program += end is not None and BY_THE_PROGRAM in end.why
        finally:
            done.set()
            poller.join(10)
        run.seconds = time.monotonic() - started_at
        run.traffic, run.loops = client.traffic.latencies, client.traffic.loops
        run.errors, run.alarms = client.traffic.errors, alarms
        return run


RUNAWAY_M = 0.3  # design.md, "Safety rules"


def kills(count: int) -> list[float]:
    """How far the robot went after each of `count` drivers was killed at speed."""
    floor = ROOT / "tests/console/open-floor.yaml"
    options = RobotOptions(floorplan=floor, firmware="later", landmarks=False,
                           virtual_port=True)  # fmt: skip
    travels: list[float] = []
    with Robot(options, Settings(), floor) as robot:
        robot.start()
        assert robot.port is not None
        for number in range(count):
            command = driving_client(robot.port.path, WHEEL_BASE_M,
                                     0.4 if number % 2 == 0 else -0.4)  # fmt: skip
            with started(command, dict(os.environ)) as client:
                if first_line(client, "the client") != "driving":
                    raise RuntimeError("the client did not start driving")
                time.sleep(random.uniform(1.0, 2.0))
                client.kill()
                client.wait(10)
                killed_at = robot.true_pose()
            assert killed_at is not None
            travels.append(went_on(robot, killed_at))
    return travels


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clients", default="ros2,ros1")
    parser.add_argument("--missions", type=int, default=10)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--busy", type=int, default=0, help="busy loops beside it")
    parser.add_argument("--kills", type=int, default=0, help="drivers killed at speed")
    args = parser.parse_args()
    if args.kills:
        return report_kills(args.kills, args.busy)
    kinds = [kind for kind in args.clients.split(",") if kind]
    if not set(kinds) <= {"ros1", "ros2"} or not kinds:
        parser.error("--clients: ros1 and/or ros2")
    folder = Path(tempfile.mkdtemp(prefix="xdg-", dir="/tmp"))
    os.environ["XDG_RUNTIME_DIR"] = str(folder)
    env = {**os.environ, "XDG_RUNTIME_DIR": str(folder), "PYTHONPATH": str(ROOT)}
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(args.busy)]
    runs: list[Run] = []
    try:
        for kind in kinds:
            runs.append(direct(kind, args.seconds, env))
            runs.append(through_the_port(kind, args.missions, env))
    finally:
        for process in busy:
            process.kill()
            process.wait(10)
        shutil.rmtree(folder, ignore_errors=True)
    load = os.getloadavg()[0]
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores; load average {load:.1f}; "
          f"{args.busy} busy loops beside it")  # fmt: skip
    print(f"{'':<34} {'p50':>6} {'p99':>6} {'max':>7}     loop rate")
    for run in runs:
        print(run.row())
        for command, line in run.errors[:6]:
            print(f"    error: {command!r} -> {line!r}")
        for alarm in run.alarms[:3]:
            print(f"    alarm: {alarm}")
    return 0


def report_kills(count: int, busy_loops: int) -> int:
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(busy_loops)]
    try:
        travels = kills(count)
    finally:
        for process in busy:
            process.kill()
            process.wait(10)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores; load average "
          f"{os.getloadavg()[0]:.1f}; {busy_loops} busy loops beside it")  # fmt: skip
    print(f"{count} drivers killed at 0.4 m/s: the robot went on {min(travels):.3f} to "
          f"{max(travels):.3f} m (median {statistics.median(travels):.3f}); "
          f"{sum(t > RUNAWAY_M for t in travels)} beyond the {RUNAWAY_M} m limit")  # fmt: skip
    return 0 if max(travels) <= RUNAWAY_M else 1


if __name__ == "__main__":
    sys.exit(main())
