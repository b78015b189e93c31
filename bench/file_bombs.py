"""Benchmark: what refusing each file bomb costs the real command (issue 30).

Each bomb of tests/fuzz/test_file_bombs.py runs once through its command, in a process
of its own; printed are its exit status, wall time, CPU time and its own peak memory
(from wait4, through the tests' launcher). The peer, in the same run, is the same command
on a good file: `floorplan check` and `floorplan show` of the example care home, and
`plan` across it. A refusal should cost no more than reading a real building does.

Usage: python bench/file_bombs.py [--deadline S]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.fuzz import test_file_bombs as bombs

EXAMPLE = Path(__file__).parents[1] / "giraff_console" / "floorplans" / "care-home.yaml"
# A case makes its file in a folder and gives the command's arguments.
Case = tuple[str, str, Callable[[Path], list[str]]]


def _plan_bomb(name: str, command: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        plan = bombs.PLAN_BOMBS[name](folder / "plan.yaml")
        return [str(plan) if arg == "FILE" else arg for arg in _COMMANDS[command]]

    return make


def _grid_bomb(name: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        image = bombs.IMAGE_BOMBS[name](folder / "grid.png")
        return ["plan", "--floorplan", str(bombs._plan_on_grid(folder, image.name)), "a", "b"]

    return make


def _building_bomb(name: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        source = bombs.BUILDING_BOMBS[name](folder / "site.building.yaml")
        return ["floorplan", "import", str(source), str(folder / "out.yaml")]

    return make


def _session_bomb(file: str, name: str) -> Callable[[Path], list[str]]:
    def make(folder: Path) -> list[str]:
        session = bombs._session(folder)
        (session / file).unlink()
        (bombs.META_BOMBS if file == "meta.json" else bombs.LOG_BOMBS)[name](session / file)
        return ["export", str(session), str(folder / "out.mcap")]

    return make


_COMMANDS = {"floorplan check": ("floorplan", "check", "FILE"), **bombs.PLAN_COMMANDS}


def cases() -> list[Case]:
    found: list[Case] = [
        ("floorplan check", "peer: the care home", lambda _: ["floorplan", "check", str(EXAMPLE)]),
        ("floorplan show", "peer: the care home", lambda _: ["floorplan", "show", str(EXAMPLE)]),
        ("plan", "peer: the care home",
         lambda _: ["plan", "--floorplan", str(EXAMPLE), "dock", "day-room"]),
    ]  # fmt: skip
    found += [("floorplan check", name, _plan_bomb(name, "floorplan check"))
              for name in bombs.PLAN_BOMBS]  # fmt: skip
    found += [(command, "100,000 markers", _plan_bomb("100,000 markers", command))
              for command in bombs.PLAN_COMMANDS]  # fmt: skip
    found += [("plan", f"grid: {name}", _grid_bomb(name)) for name in bombs.IMAGE_BOMBS]
    found += [("floorplan import", name, _building_bomb(name)) for name in bombs.BUILDING_BOMBS]
    found += [("export", f"control.log: {name}", _session_bomb("control.log", name))
              for name in bombs.LOG_BOMBS]  # fmt: skip
    found += [("export", f"meta.json: {name}", _session_bomb("meta.json", name))
              for name in bombs.META_BOMBS]  # fmt: skip
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--deadline", type=float, default=60.0,
                        help="seconds before a command is killed (default: 60)")  # fmt: skip
    args = parser.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f}")  # fmt: skip
    print(f"{'command':28} {'file':38} {'exit':>4} {'wall s':>7} {'CPU s':>6} {'peak MB':>8}")
    for command, name, make in cases():
        with tempfile.TemporaryDirectory() as folder:
            ended = bombs.run_bounded(Path(folder), *make(Path(folder)), deadline=args.deadline)
        print(f"{command:28} {name:38} {ended.status!s:>4} {ended.seconds:7.2f} "
              f"{ended.cpu_seconds:6.2f} {ended.peak_kib / 1024:8.0f}", flush=True)  # fmt: skip
    print(f"load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
