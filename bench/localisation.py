"""Benchmark: how far from where it should be the robot really stands at every stop of a
night patrol, with dead reckoning alone and with the plan's markers (issue 14).

A patrol through every room of the example care home (a nearest-first tour from the
dock, back to the dock at the end), several rounds, on the simulator with its
imperfections (distance errors, and the casters turning the robot up to 45° after a turn
on the spot, §3.2.1.5), one process per seed, run with `giraff-console patrol --json`:
- dead reckoning only (`--no-landmarks`): what the console had before issue 14;
- landmarks: the odometry corrected by the markers the simulated camera sees;
- landmarks, with one marker moved along its wall in the building but not in the plan
  (first seed only): the gate should reject it, and the figures should still hold.
At every stop: the error from the true pose to the room's point (metres) and heading
(degrees), median, p95 and worst, over the stops that arrived; the stops that did not,
and why (the patrol ends there); the estimate's own standard deviation; the camera's
cost per frame in wall time (rendering the synthetic frame, and finding its markers).

`--faults on` lets the simulator make its random stalls (1 s) and ESTOPs too, which end
a mission by design (and so the patrol): they are reported as "ended early". The
default is `--faults off`, so that every stop is driven to; the header says which.

Usage: python bench/localisation.py [--seeds 1-8] [--rounds 3] [--rooms N] [--jobs 2]
       [--faults off|on] [--move-marker ID:DX] [--eye-fps F] [--eye-size WxH] [--save FILE]
Quick: python bench/localisation.py --seeds 1 --rounds 1 --rooms 5
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import giraff_console
from giraff_console.missions.survey import tour
from giraff_console.planning.floorplan import load_floorplan

EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"
# Beside the kitchen door, on the dining room's east wall: the patrol passes it going
# from the dining room to the kitchen. 1 m along the wall is away from the doorway.
MOVED_MARKER = "53:1"
# The bounds at every stop, with landmarks: error and heading, worst and p95.
WORST_M, WORST_DEG, P95_M = 0.10, 3.0, 0.05


@dataclass
class Run:
    """One patrol process: its stop lines and its last line."""

    mode: str
    seed: int
    stops: list[dict] = field(default_factory=list)
    summary: dict | None = None
    code: int | None = None
    wall_s: float = 0.0
    problem: str | None = None  # the process failed: usage error, timeout, crash


def patrol_command(path: Path, seed: int, args: argparse.Namespace, *extra: str) -> list[str]:
    return [
        sys.executable, "-m", "giraff_console", "patrol", str(path), "--sim",
        "--sim-speed", "inf", "--json", "--imperfect", "--seed", str(seed),
        "--faults", args.faults, "--eye-fps", str(args.eye_fps), "--eye-size", args.eye_size,
        *extra,
    ]  # fmt: skip


def run_patrol(run: Run, command: list[str], timeout: float) -> Run:
    began = time.perf_counter()
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        run.problem = f"timed out after {timeout:.0f} s"
        return run
    run.wall_s = time.perf_counter() - began
    run.code = result.returncode
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    if lines and "patrol" in lines[-1]:
        run.summary = lines.pop()
    run.stops = lines
    if run.code not in (0, 1) or run.summary is None:
        tail = result.stderr.strip().splitlines()[-3:]
        run.problem = f"exit {run.code}: {' / '.join(tail)}"
    return run


def figures(values: list[float]) -> str:
    if not values:
        return f"{'-':>7}{'-':>7}{'-':>7}"
    median, p95 = np.percentile(values, [50, 95])
    return f"{median:>7.3f}{p95:>7.3f}{max(values):>7.3f}"


def table(runs: list[Run], modes: list[str]) -> None:
    print(f"{'':<34}{'stops':>10} | {'error m':^21} | {'heading °':^21} | {'sigma':>6} | "
          f"{'ended':>5} | {'camera ms/frame':>15}")  # fmt: skip
    print(f"{'':<34}{'arrived':>10} | {'median':>7}{'p95':>7}{'worst':>7} | "
          f"{'median':>7}{'p95':>7}{'worst':>7} | {'median':>6} | {'early':>5} | "
          f"{'all':>7}{'detect':>8}")  # fmt: skip
    for mode in modes:
        mine = [run for run in runs if run.mode == mode]
        arrived = [s for run in mine for s in run.stops if s["arrived"]]
        planned = sum(run.summary["stops"] for run in mine if run.summary)
        early = sum(1 for run in mine if run.summary and run.summary["why"] != "done")
        sigma = np.median([s["sigma_m"] for s in arrived]) if arrived else math.nan
        eyes = [run.summary["eye"] for run in mine if run.summary and run.summary["eye"]]
        look = np.median([e["ms_per_frame"] for e in eyes if e["frames"]]) if eyes else None
        detect = (
            np.median([e["detect_ms_per_frame"] for e in eyes if e["frames"]]) if eyes else None
        )
        camera = "-" if look is None else f"{look:>7.1f}{detect:>8.1f}"
        print(f"{mode:<34}{f'{len(arrived)}/{planned}':>10} | "
              f"{figures([s['error_m'] for s in arrived])} | "
              f"{figures([s['heading_error_deg'] for s in arrived])} | {sigma:>6.3f} | "
              f"{early:>5} | {camera:>15}")  # fmt: skip


def details(runs: list[Run], moved: str | None) -> None:
    """What did not arrive and why, the moved marker, and the issue's bounds."""
    for run in sorted(runs, key=lambda run: (run.mode, run.seed)):
        if run.problem is not None:
            print(f"  {run.mode}, seed {run.seed}: FAILED: {run.problem}")
        for stop in run.stops:
            if not stop["arrived"]:
                print(f"  {run.mode}, seed {run.seed}: ended early at round {stop['round']}, "
                      f"stop {stop['stop']} ({stop['room'] or stop['route']}), "
                      f"{stop['t_s']:.0f} s in: {stop['why']}")  # fmt: skip
    if moved is not None:
        marker = int(moved.split(":")[0])
        for run in (run for run in runs if run.mode.startswith("landmarks, marker")):
            if run.summary is None:
                continue
            rejected = marker in run.summary["markers_rejected"]
            used = marker in run.summary["markers_used"]
            verdict = ("rejected by the gate" if rejected else "not rejected") + (
                ", and used to correct the pose" if used else ", never used"
            )
            if not (rejected or used):
                verdict = "neither used nor rejected: not on this patrol's way (--move-marker)"
            print(f"  {run.mode}, seed {run.seed}: marker {marker} {verdict}")
    for run in (run for run in runs if run.mode.startswith("landmarks")):
        arrived = [s for s in run.stops if s["arrived"]]
        if run.summary is None or not arrived:
            continue
        errors = [s["error_m"] for s in arrived]
        headings = [s["heading_error_deg"] for s in arrived]
        p95 = float(np.percentile(errors, 95))
        missed = [
            f"{run.summary['stops'] - len(arrived)} stops not arrived"
            if len(arrived) < run.summary["stops"] else "",
            f"worst {max(errors):.3f} m > {WORST_M} m" if max(errors) > WORST_M else "",
            f"worst {max(headings):.2f}° > {WORST_DEG}°" if max(headings) > WORST_DEG else "",
            f"p95 {p95:.3f} m > {P95_M} m" if p95 > P95_M else "",
        ]  # fmt: skip
        if any(missed):
            print(f"  {run.mode}, seed {run.seed}: issue 14's bounds not met: "
                  f"{', '.join(text for text in missed if text)}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-8", metavar="A-B|A,B,..",
                        help="imperfection seeds (default %(default)s)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default %(default)s)")
    parser.add_argument("--rooms", type=int, metavar="N",
                        help="the first N stops of the tour only (default: all)")  # fmt: skip
    parser.add_argument("--jobs", type=int, default=2, help="processes at once (default 2)")
    parser.add_argument("--faults", choices=("on", "off"), default="off",
                        help="random stalls and ESTOPs (default %(default)s)")  # fmt: skip
    parser.add_argument("--move-marker", default=MOVED_MARKER, metavar="ID:DX",
                        help="the marker moved in the gate run (default %(default)s); "
                             "'none' for no such run")  # fmt: skip
    parser.add_argument("--eye-fps", type=float, default=10.0, help="camera frames/s")
    parser.add_argument("--eye-size", default="800x600", metavar="WxH", help="camera frame")
    parser.add_argument("--timeout", type=float, default=6 * 3600.0, metavar="S",
                        help="seconds a patrol process may take (default %(default)s)")  # fmt: skip
    parser.add_argument("--save", type=Path, metavar="FILE",
                        help="write every line of every run, labelled, as JSON")  # fmt: skip
    args = parser.parse_args()
    if "-" in args.seeds:
        first, last = (int(part) for part in args.seeds.split("-"))
        seeds = list(range(first, last + 1))
    else:
        seeds = [int(part) for part in args.seeds.split(",")]
    plan = load_floorplan(EXAMPLE)
    stops = tour(plan)[: args.rooms]
    moved = None if args.move_marker == "none" else args.move_marker
    modes = ["dead reckoning", "landmarks"]
    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cores; {args.jobs} at once")  # fmt: skip
    print(f"patrol: {args.rounds} rounds of {len(stops)} stops ({', '.join(stops)}), "
          f"seeds {seeds[0]}..{seeds[-1]}; --imperfect with random stalls and ESTOPs "
          f"{args.faults}; camera {args.eye_size} at {args.eye_fps:g} fps")  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "night.patrol.yaml"
        path.write_text(yaml.safe_dump({"rounds": args.rounds,
                                        "stops": [{"room": room} for room in stops]}))  # fmt: skip
        jobs: list[tuple[Run, list[str]]] = []
        for seed in seeds:
            alone = patrol_command(path, seed, args, "--no-landmarks")
            jobs.append((Run("dead reckoning", seed), alone))
            jobs.append((Run("landmarks", seed), patrol_command(path, seed, args)))
        if moved is not None:
            mode = f"landmarks, marker {moved.replace(':', ' moved ')} m"
            modes.append(mode)
            jobs.append((Run(mode, seeds[0]), patrol_command(path, seeds[0], args,
                                                             "--move-marker", moved)))  # fmt: skip
        began = time.perf_counter()
        runs = []
        with ThreadPoolExecutor(args.jobs) as pool:
            futures = [pool.submit(run_patrol, run, command, args.timeout) for run, command in jobs]
            for future in as_completed(futures):
                run = future.result()
                runs.append(run)
                arrived = sum(stop["arrived"] for stop in run.stops)
                print(f"  done: {run.mode}, seed {run.seed}: {arrived} stops arrived, "
                      f"{run.wall_s:.0f} s", file=sys.stderr)  # fmt: skip
    print()
    table(runs, modes)
    details(runs, moved)
    print(f"figures over the stops that arrived; benchmark {time.perf_counter() - began:.0f} s")
    if args.save is not None:
        with args.save.open("w") as out:
            for run in runs:
                for line in [*run.stops, run.summary]:
                    out.write(
                        json.dumps({"mode": run.mode, "seed": run.seed, **(line or {})}) + "\n"
                    )


if __name__ == "__main__":
    main()
