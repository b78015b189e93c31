"""Benchmark: curves as one `set twm` on Giraff-X against separate `set`s (issue 13).

Giraff-X added `set twm vg cdp vgr v p 0` because a curve sent as several `set`s made
the motors jerk and pause (wire-facts, "Later firmware"). On a board that has it (the
probe says so), the control loop folds each batch of a curved move into one twm
(robot/twm.py, OdometryFeed.moves). This drives
the same curves on the thesis's board (separate sets) and on Giraff-X (twm), each on a
fresh in-process simulator on a virtual clock with a fresh control loop at 20 Hz:

- teleop: forward for 1 s, forward-right for 3 s, forward-left for 3 s, then the keys
  let go until the robot stands still;
- `go` from the example care home's dock to a room (the lobby by default), along
  clothoid turns (missions/go_to.py).

It counts, per control tick, the motion commands (the `set`s and twms; the polls are
the same on both) and their bytes both ways, and the time those take on a 115200-baud
line: on a board that acted on each `set` as it came, that is how long it would run a
move that is part old, part new. It samples the simulator's gear ratio (cvg) every
5 ms and counts steps: the guard allows a ramp of at most 2 per metre (MAX_GEAR_RATE)
at 0.4 m/s, at most 0.004 in 5 ms, so a change of more than 0.01 in one sample is no
ramp. Since no time passes during an exchange on the virtual clock, the change of cvg
across each command is what that command did to it at once.

What the simulator can and cannot show: it stages every setting for the next move and
starts a move only at `set p` (or twm), from the ratio the robot has (sim/board.py,
sim/drive.py), so separate sets cannot jerk it, and its gear ratio only ever ramps. The
jerk and pause of a real board between separate sets are not modelled; the figures
here are the commands, bytes and line time that twm saves, and a check that both ways
drive the same path.

Usage: python bench/twm.py [--room ROOM]  (or python bench/motion.py --twm)
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import giraff_console
from giraff_console.clock import VirtualClock
from giraff_console.link import BoardLink, Exchange
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol.codec import parse_command
from giraff_console.protocol.framing import BYTE_TIME_S, LINE_END, PROMPT
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.mission import MissionEnd
from giraff_console.robot.teleop import Teleop
from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.drive import TruePose

EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"
TICK_S = 0.05  # the control loop's 20 Hz
SAMPLES_PER_TICK = 10  # the gear ratio every 5 ms
# A change of the gear ratio in one 5 ms sample beyond this is a step, not a ramp (above).
GEAR_STEP = 0.01
FIRMWARES = ("thesis", "giraff-x")
TELEOP = ((Intent.FORWARD, 1.0), (Intent.FORWARD_RIGHT, 3.0), (Intent.FORWARD_LEFT, 3.0))
# A run still going after this long has gone wrong.
TIMEOUT_S = 300.0


def exchange_bytes(exchange: Exchange) -> int:
    """The bytes of an exchange both ways: the command and its CR, the answer, the prompt."""
    answer = sum(len(line) + len(LINE_END) for line in exchange.lines)
    return len(exchange.command) + 1 + answer + len(PROMPT) + len(LINE_END)


@dataclass
class Watch:
    """What went on the wire each tick, and the gear ratio as it went."""

    board: GiraffBoard
    tick: int = 0
    commands: dict[int, list[tuple[str, int]]] = field(default_factory=dict)
    cvg: float = 0.0
    speed: float = 0.0
    steps_moving: int = 0
    steps_at_rest: int = 0
    # The largest change of cvg across a command, at once, by the command's name.
    at_command: dict[str, float] = field(default_factory=dict)

    def exchange(self, exchange: Exchange) -> None:
        drive = self.board.drive
        if exchange.kind == "set" and not exchange.automatic:
            size = exchange_bytes(exchange)
            self.commands.setdefault(self.tick, []).append((exchange.command, size))
            name = exchange.command.split()[1]
            change = abs(drive.cvg - self.cvg)
            self.at_command[name] = max(self.at_command.get(name, 0.0), change)
        self.cvg, self.speed = drive.cvg, abs(drive.velocity)

    def sample(self) -> None:
        """The gear ratio now (the board brought up to the clock)."""
        self.board.true_pose  # noqa: B018  brings the wheels up to the clock
        drive = self.board.drive
        if abs(drive.cvg - self.cvg) > GEAR_STEP:
            if self.speed > 0 and abs(drive.velocity) > 0:
                self.steps_moving += 1
            else:
                self.steps_at_rest += 1
        self.cvg, self.speed = drive.cvg, abs(drive.velocity)


@dataclass
class Result:
    ticks: int
    commands: list[int]  # per tick, every tick of the drive
    sizes: list[int]  # bytes per tick, both ways
    twms: int
    longest: int  # characters of the longest motion command
    watch: Watch
    end: TruePose
    why: str


def run(firmware: str, drive: Callable[[ControlLoop, BoardLink, Watch], str]) -> Result:
    """One drive on a fresh board and control loop."""
    link = BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}")
    clock, board = link.port.clock, link.port.board
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    watch = Watch(board)
    link.add_observer(watch.exchange)
    # Connects: a stop, settings within the limits, and the probe, which tells the loop
    # whether the board takes twm (then it folds each batch: OdometryFeed.moves).
    control.tick()
    watch.commands.clear()
    watch.tick = first = 1
    why = drive(control, link, watch)
    control.shutdown()
    ticks = range(first, watch.tick)
    counts = [len(watch.commands.get(t, [])) for t in ticks]
    sizes = [sum(size for _, size in watch.commands.get(t, [])) for t in ticks]
    sent = [text for t in ticks for text, _ in watch.commands.get(t, [])]
    return Result(len(ticks), counts, sizes, sum(text.startswith("set twm") for text in sent),
                  max(map(len, sent), default=0), watch, board.true_pose, why)  # fmt: skip


def step(control: ControlLoop, watch: Watch) -> None:
    """One control tick, then a tick's time in 5 ms samples of the gear ratio."""
    control.tick()
    watch.tick += 1
    clock = control.clock
    assert isinstance(clock, VirtualClock)
    for _ in range(SAMPLES_PER_TICK):
        clock.advance(TICK_S / SAMPLES_PER_TICK)
        watch.sample()


def teleop_curves(control: ControlLoop, link: BoardLink, watch: Watch) -> str:
    """The keys held (repeated every tick, within the deadman's grace), then let go."""
    for intent, seconds in TELEOP:
        for _ in range(round(seconds / TICK_S)):
            control.press(intent)
            step(control, watch)
    control.halt()
    for _ in range(round(10 / TICK_S)):
        step(control, watch)
        if not link.port.board.drive.velocity and not control.teleop.active:
            return "stopped"
    return "still moving"


def go_to(room: str) -> Callable[[ControlLoop, BoardLink, Watch], str]:
    plan = load_floorplan(EXAMPLE)

    def drive(control: ControlLoop, link: BoardLink, watch: Watch) -> str:
        navigator = Navigator(plan, walls_of(plan))
        start = navigator.start_pose
        assert start is not None, "the example plan has a start room"
        control.odometry.reset(start)
        link.port.board.place(TruePose(start.x, start.y, start.heading))
        mission = GoTo(navigator, room, lambda: control.odometry.pose, tick=TICK_S)
        ended: list[MissionEnd] = []
        began = control.clock.now()
        control.run_mission(mission, ended.append)
        while not ended and control.clock.now() - began < TIMEOUT_S:
            step(control, watch)
        return ended[0].why if ended else "timed out"

    return drive


def course_after_each_command() -> list[tuple[str, float]]:
    """A right curve under way on the thesis's board, then a left one sent as separate
    sets, each after the line time of the one before (115200 baud, answer included):
    the ramp of the gear ratio, per metre of path, over the line time after each."""
    link = BoardLink.open("giraff-sim://?clock=virtual")
    clock, drive = link.port.clock, link.port.board.drive
    for text in ("set r 1000", "set mode 0", "set a 0.5", "set v 0.27", "set vgr 1",
                 "set vg 0.49", "set cdp 0.25", "set p 0.25"):  # fmt: skip
        link.send(parse_command(text))
    clock.advance(0.5)  # the ratio ramps up towards 0.49 at 1 per metre
    ramps = []
    for text in ("set vgr -1", "set vg -0.49", "set p 0.25"):
        size = exchange_bytes(link.send(parse_command(text)))
        ratio, path = drive.cvg, (drive.left_odometer + drive.right_odometer) / 2
        clock.advance(size * BYTE_TIME_S)
        link.port.board.true_pose  # noqa: B018  brings the wheels up to the clock
        travelled = (drive.left_odometer + drive.right_odometer) / 2 - path
        ramps.append((text, (drive.cvg - ratio) / travelled))
    link.close()
    return ramps


def row(label: str, firmware: str, r: Result) -> str:
    sending = [size for size in r.sizes if size]
    return (f"{label:<14}{firmware:<10}{r.ticks:>6}{sum(r.commands):>6}"
            f"{statistics.mean(r.commands):>7.2f}{max(r.commands):>5}"
            f"{statistics.mean(r.sizes):>8.1f}{max(r.sizes):>6}"
            f"{statistics.mean(sending) * BYTE_TIME_S * 1e3:>9.2f}"
            f"{max(r.sizes) * BYTE_TIME_S * 1e3:>8.2f}{r.twms:>6}{r.longest:>6}"
            f"{r.watch.steps_moving:>7}{r.watch.steps_at_rest:>6}"
            f"{max(r.watch.at_command.values(), default=0.0):>8.4f}  {r.why}")  # fmt: skip


def compare(room: str) -> None:
    """Both drives on both boards, one row each, and how far apart the drives ended."""
    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cores")  # fmt: skip
    print("curves: separate sets (thesis board) against one twm per change (Giraff-X); "
          "in-process simulator, 20 Hz virtual clock, cvg sampled every 5 ms")  # fmt: skip
    print(f"{'drive':<14}{'board':<10}{'ticks':>6}{'cmds':>6}{'/tick':>7}{'max':>5}"
          f"{'B/tick':>8}{'max':>6}{'line ms':>9}{'max':>8}{'twm':>6}{'chars':>6}"
          f"{'steps':>7}{'rest':>6}{'at cmd':>8}")  # fmt: skip
    drives = (("teleop 7 s", teleop_curves), (f"go {room}", go_to(room)))
    for label, drive in drives:
        results = {firmware: run(firmware, drive) for firmware in FIRMWARES}
        for firmware, result in results.items():
            print(row(label, firmware, result))
        if len({result.why for result in results.values()}) > 1:
            print(f"{'':<14}the two ended differently: their paths are not compared")
            continue
        a, b = (results[firmware].end for firmware in FIRMWARES)
        apart = math.hypot(a.x - b.x, a.y - b.y) * 1e3
        turn = math.degrees(abs(a.heading - b.heading))
        print(f"{'':<14}the two ended {apart:.2f} mm and {turn:.3f}° apart (true poses)")
    ramps = ", ".join(f"{text}: {ramp:+.2f}" for text, ramp in course_after_each_command())
    print(f"a right curve turned left by separate sets, each a line time after the other; "
          f"the ratio's ramp per metre after each: {ramps}")  # fmt: skip
    print("cmds: motion commands (sets, twms); /tick, max: per control tick over the drive; "
          "B/tick: their bytes both ways; line ms: their time at 115200 baud per tick that "
          "sends (mean, max); chars: the longest; steps, rest: gear-ratio steps "
          f"(> {GEAR_STEP} in 5 ms) with the wheels turning, at rest; at cmd: the largest "
          "change of cvg across one command")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--room", default="lobby", help="where `go` drives (default lobby)")
    args = parser.parse_args()
    compare(args.room)


if __name__ == "__main__":
    main()
