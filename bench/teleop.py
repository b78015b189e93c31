"""Benchmark: teleop latencies, control-loop jitter under a busy screen, run-on after a kill.

Everything runs against `giraff-console sim --pty --pace` in another process, so each
exchange takes its real 115200-baud line time.

1. Key to wire: from a first key press to the first command of the move and to the
   command that starts it (`set p`) on the wire; the console headless, its control
   loop on its own thread at 20 Hz. The first trial sends the whole set-up; later ones
   only what the board does not already hold.
2. Release to stop: from the last key repeat to the stop command (`set p` of the
   braking distance plus 10 ms).
3. Jitter: how late control ticks start while the screen is kept busy (30 ms of work
   every 50 ms on the UI thread).
4. Run-on: the real console in a pseudo-terminal, killed with SIGKILL mid-move, so no
   handler runs; the board carries on with its last target (design.md's worst case).

Usage: python bench/teleop.py [--trials N]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

from textual import events

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.clock import RealClock
from giraff_console.link import BoardLink
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.loop_events import ExchangeTap, LoopEvent
from giraff_console.robot.telemetry import Telemetry
from giraff_console.robot.teleop import Teleop
from giraff_console.service.robot_service import RobotService
from giraff_console.tui.app import GiraffConsole
from tests.conftest import start_sim_process, stop_sim_process
from tests.console.support import (
    SimulatedRobot,
    drain,
    hold_up,
    pose_at,
    settled,
    spawn_console,
)


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(share * (len(ordered) - 1)))]


def console_on(path: str) -> tuple[GiraffConsole, ControlLoop, list[tuple[float, str]]]:
    clock = RealClock()
    control = ControlLoop(
        lambda: BoardLink.open(path), teleop=Teleop(), deadman=Deadman(clock), clock=clock
    )
    wire: list[tuple[float, str]] = []
    control.subscribe(ExchangeTap(lambda e: wire.append((e.sent_at, e.command))))
    robot = RobotService(control, DriveSetup.on_loop(control, None))
    # The screen is given the service and callables to start and stop the loop (issue 26).
    app = GiraffConsole(robot, clock=clock, simulator=False, started=control.start,
                        stop=control.stop)  # fmt: skip
    return app, control, wire


def motion(command: str) -> bool:
    return command.startswith("set ")


def target(command: str) -> bool:
    return command.startswith("set p ")


def stop(command: str) -> bool:
    return target(command) and float(command.split()[2]) < 0.2


async def wait_for(wire: list[tuple[float, str]], wanted, after: float, limit: float = 3):
    """When the first command that `wanted` accepts went out after `after`."""
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        for sent_at, sent in wire:
            if sent_at >= after and wanted(sent):
                return sent_at
        await asyncio.sleep(0.001)
    raise RuntimeError(f"no {wanted.__name__} command went out")


async def latencies(path: str, trials: int) -> dict[str, list[float]]:
    app, control, wire = console_on(path)
    results: dict[str, list[float]] = {
        "key to first command": [], "key to set p": [], "last repeat to stop": [],
    }  # fmt: skip
    async with app.run_test(size=(100, 30)) as pilot:
        await asyncio.sleep(1.0)
        for _ in range(trials):
            pressed = time.monotonic()
            await pilot.press("up")
            first = await wait_for(wire, motion, pressed)
            results["key to first command"].append(first - pressed)
            results["key to set p"].append(await wait_for(wire, target, pressed) - pressed)
            await asyncio.sleep(0.5 - (time.monotonic() - pressed))
            last = time.monotonic()
            driver = app._driver  # what a terminal's repeats come through
            assert driver is not None
            while time.monotonic() < pressed + 1.0:  # terminal auto-repeat
                driver.send_message(events.Key("up", None))
                last = time.monotonic()
                await asyncio.sleep(0.033)
            results["last repeat to stop"].append(await wait_for(wire, stop, last) - last)
            await asyncio.sleep(1.2)  # braked to a stop
    control.stop()  # the console's own leaving stops it; a test's does not
    return results


async def jitter(path: str, seconds: float) -> list[float]:
    app, control, _ = console_on(path)
    late: list[float] = []

    def lateness(event: LoopEvent) -> None:
        if isinstance(event, Telemetry):
            late.append(event.late_ms)

    def busy() -> None:
        end = time.perf_counter() + 0.030
        while time.perf_counter() < end:
            pass

    async with app.run_test(size=(100, 30)):
        control.subscribe(lateness)
        app.set_interval(0.05, busy)
        await asyncio.sleep(seconds)
    control.stop()
    return late[20:]


def run_on_after_kill(robot: SimulatedRobot) -> float:
    pid, master = spawn_console(robot.path)
    drain(master, 3.0)
    hold_up(master, 3.0)
    killed = time.monotonic()
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    os.close(master)
    robot.wait_until_still()
    samples = robot.samples()
    return settled(samples, killed).x - pose_at(samples, killed).x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=30)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        robot = SimulatedRobot(Path(scratch))
        try:
            run_on = [run_on_after_kill(robot) for _ in range(3)]
        finally:
            robot.close()
    process, path = start_sim_process("--pace")
    try:
        lat = asyncio.run(latencies(path, args.trials))
        late = asyncio.run(jitter(path, 10.0))
    finally:
        stop_sim_process(process)
    print(f"teleop over a paced pty, {args.trials} trials, control loop at 20 Hz")
    print(f"{'measure':<28}{'p50 ms':>9}{'p95 ms':>9}{'max ms':>9}")
    for name, values in lat.items():
        ms = [v * 1e3 for v in values]
        print(f"{name:<28}{percentile(ms, 0.5):>9.1f}{percentile(ms, 0.95):>9.1f}{max(ms):>9.1f}")
    print(f"{'tick lateness, busy screen':<28}{percentile(late, 0.5):>9.1f}"
          f"{percentile(late, 0.95):>9.1f}{max(late):>9.1f}   (period 50 ms)")  # fmt: skip
    print(f"run-on after SIGKILL at 0.4 m/s: {', '.join(f'{r:.3f}' for r in run_on)} m "
          f"(limit 0.3 m)")  # fmt: skip
    print(f"mean tick lateness {statistics.mean(late):.1f} ms over {len(late)} ticks")


if __name__ == "__main__":
    main()
