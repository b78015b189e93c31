"""Benchmark: a building taught by driving it once (issue 29, the first "Done when").

A building of our own making (tests/teaching/), with its markers put up by `floorplan
landmarks` on the truth, the console shown nothing of it:

1. **Mapping.** The console starts on a plan of the dock alone, the simulator put in the
   building (`--sim-building`), `--imperfect --seed MAP_SEED --faults off`, the simulated
   lidar read through the real reading code. `map`, then a scripted operator drives
   through every room with the arrow keys (tests/teaching/operator.py) and types `mark
   ROOM` in each, then `map save`: the map (ROS map_server) and the plan made of it.
   Said: the rooms the plan has against the real rooms (one each, ± 1), the marked names
   found, the map's occupied cells within 0.10 m of the truth's, how the lidar and the
   mapping kept up (revolutions, dropped, CPU of each thread).
2. **Markers.** `giraff-console survey` on the plan made, in the same building (`--sim
   --sim-building TRUTH`), writes the markers it finds into it.
3. **Going.** For seeds 1-8, a patrol of 10 rooms of the plan made (one from each of 10
   parts, bench/any_building.py's choice) with `--sim-building TRUTH` and the lidar
   the robot was taught with (`--lidar`: its revolutions fitted to the plan's map
   correct the pose, and it senses what is in the way), judged against the true pose
   as bench/any_building.py judges: within 0.10 m and 3° (the heading where the room
   has one). The lidar is read at its own pace, so the simulator runs at
   PATROL_SPEED, not as fast as it can.

Usage: python bench/teach_building.py [--building flat|hall] [--seeds 1-8] [--rooms 10]
       [--map-seed 1] [--jobs 2] [--folder DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.any_building import (
    MARKERS,
    Run,
    counts,
    machine,
    misclaimed,
    patrol_command,
    patrol_rooms,
    run_patrol,
    seeds_of,
    source,
    write_patrol,
)
from bench.survey import survey
from giraff_console.lidar import SIMULATED_LIDAR
from giraff_console.planning.floorplan import FloorPlan, load_floorplan
from giraff_console.planning.route_planner import RoutePlanner, walls_of
from giraff_console.planning.scan_grid import read_scan
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.settings import Settings
from tests.buildings.console import put_up_markers
from tests.teaching import BUILDINGS, Teaching
from tests.teaching.flat import unmapped_plan
from tests.teaching.map_truth import map_truth
from tests.teaching.operator import Operator, tour

PATROL_TIMEOUT_S = 3600.0
# The patrols' clock against the wall's: tests/lidar/test_go_with_lidar.py's, beside
# another patrol (--jobs 2).
PATROL_SPEED = "2"
DRIVE_TIMEOUT_S = 1800.0


def thread_cpu(names: tuple[str, ...]) -> dict[str, float]:
    """CPU seconds so far of this process's threads called `names` (Linux's /proc)."""
    seconds: dict[str, float] = dict.fromkeys(names, 0.0)
    tick = 100.0  # USER_HZ
    for thread in threading.enumerate():
        if thread.name in names and thread.native_id is not None:
            try:
                stat = Path(f"/proc/self/task/{thread.native_id}/stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            seconds[thread.name] += (int(fields[11]) + int(fields[12])) / tick
    return seconds


def map_it(teaching: Teaching, folder: Path, seed: int, sim_speed: float = 2.0) -> dict:
    """The mapping drive; what it made, and how it went."""
    truth = load_floorplan(teaching.truth)
    blank = unmapped_plan(folder, teaching.dock)
    options = RobotOptions(floorplan=blank, sim_building=teaching.truth, sim_speed=sim_speed,
                           imperfect_seed=seed, faults=False, lidar=SIMULATED_LIDAR)  # fmt: skip
    out = folder / f"{teaching.name}-mapped"
    with Robot(options, Settings(), teaching.truth) as robot:
        robot.start()
        began = time.perf_counter()
        started = robot.service.execute(c.StartMapping())
        assert started.ok, started.text
        cpu_before = thread_cpu(("lidar", "mapping"))
        drive = Operator(robot, DRIVE_TIMEOUT_S).drive(tour(truth, teaching.tour))
        cpu_after = thread_cpu(("lidar", "mapping"))
        run = robot.service.building_map.run
        status = run.status() if run is not None else None
        lidar = robot.lidar
        revolutions = lidar.revolutions if lidar is not None else 0
        saved = robot.service.execute(c.SaveMap(out))
        wall = time.perf_counter() - began
    report: dict = {"marked": drive.marked, "metres": drive.metres, "drive_s": drive.seconds,
                    "wall_s": wall, "saved": saved.ok, "said": saved.text,
                    "lines": list(saved.lines), "revolutions": revolutions}  # fmt: skip
    if status is not None:
        report |= {"laid_in": status.scans, "dropped": status.dropped,
                   "unplaced": status.unplaced, "broken": status.broken}  # fmt: skip
    # Of a core, over the wall's seconds; the simulated clock runs `sim_speed` times as
    # fast, and the lidar's revolutions with it (5.5 a simulated second when it keeps up).
    report["revolutions_per_sim_s"] = revolutions / (drive.seconds * sim_speed)
    for name in ("lidar", "mapping"):
        report[f"cpu_{name}_percent"] = 100 * (cpu_after[name] - cpu_before[name]) / drive.seconds
    if saved.ok:
        plan = load_floorplan(out.with_suffix(".yaml"))
        report |= judge_plan(plan, truth, teaching) | judge_map(out, truth)
        report["plan"] = str(plan.path)
    return report


def judge_plan(plan: FloorPlan, truth: FloorPlan, teaching: Teaching) -> dict:
    real = RoutePlanner(truth, walls_of(truth))
    named_right = [name for name in teaching.tour if name in plan.rooms
                   and real.room_at(plan.rooms[name].at) == name]  # fmt: skip
    return {
        "rooms": len(plan.rooms),
        "real_rooms": teaching.real_rooms,
        "named_right": len(named_right),
        "marked_rooms": len(set(teaching.tour)),
    }


def judge_map(out: Path, truth: FloorPlan) -> dict:
    grid = walls_of(truth)
    assert grid is not None
    judged = map_truth(read_scan(out.with_name(f"{out.name}-map.yaml")).grid, grid)
    return {"occupied_cells": judged.occupied, "within_5cm": judged.within_5cm,
            "within_10cm": judged.within_10cm}  # fmt: skip


def teach(teaching: Teaching, folder: Path, map_seed: int, sim_speed: float) -> Path | None:
    """Map the building and survey its markers; the plan made, or None if none was saved."""
    mapped = map_it(teaching, folder, map_seed, sim_speed)
    print("mapping:", json.dumps(mapped, indent=1), flush=True)
    if not mapped.get("saved"):
        print("NOT MET: the map was not saved")
        return None
    plan_path = Path(mapped["plan"])
    truth = load_floorplan(teaching.truth)
    assert truth.landmarks is not None  # put up by main
    # The plan made has no markers' family and size: the building's are given.
    surveyed = survey(plan_path, teaching.truth, map_seed, "--sim-building",
                      str(teaching.truth), "--family", truth.landmarks.family,
                      "--size", str(truth.landmarks.size))  # fmt: skip
    print("survey:", json.dumps({k: v for k, v in surveyed.items() if k != "markers"}),
          f"{len(surveyed.get('markers', []))} markers", flush=True)  # fmt: skip
    return plan_path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--building", choices=sorted(BUILDINGS), default="flat")
    parser.add_argument("--seeds", default="1-8")
    parser.add_argument("--rooms", type=int, default=10)
    parser.add_argument("--map-seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--folder", type=Path)
    parser.add_argument("--sim-speed", type=float, default=2.0,
                        help="the mapping drive's clock against the wall's (1: the lidar's "
                             "own pace, for a busy machine)")  # fmt: skip
    parser.add_argument("--patrols-only", action="store_true",
                        help="patrol the plan a run before taught and surveyed in --folder, "
                             "without mapping or surveying again")  # fmt: skip
    args = parser.parse_args()
    if args.patrols_only and args.folder is None:
        parser.error("--patrols-only needs the --folder a run before taught")
    folder = args.folder or Path(tempfile.mkdtemp(prefix="teach-building-"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"machine: {machine()}; source: {source()}; folder {folder}", flush=True)
    teaching = BUILDINGS[args.building](folder)
    markers = put_up_markers(teaching.truth)
    truth = load_floorplan(teaching.truth)
    print(f"{args.building}: {teaching.real_rooms} real rooms, {len(truth.doors)} doors, "
          f"{markers.placed} markers put up; the tour marks {len(teaching.tour)} stops",
          flush=True)  # fmt: skip

    if args.patrols_only:
        plan_path: Path | None = folder / f"{teaching.name}-mapped.yaml"
        if not plan_path.is_file():
            print(f"NOT RUN: no {plan_path}; teach the building first (without --patrols-only)")
            return
    else:
        plan_path = teach(teaching, folder, args.map_seed, args.sim_speed)
        if plan_path is None:
            return
    plan = load_floorplan(plan_path)
    runs = []
    for seed in seeds_of(args.seeds):
        rooms = patrol_rooms(plan, seed, args.rooms)
        patrol = write_patrol(folder / f"patrol-{seed}.patrol.yaml", rooms, 1)
        run = Run(args.building, MARKERS, seed, rooms, 1)
        run.command = patrol_command(patrol, plan_path, seed, "--sim-building", str(truth.path),
                                     "--lidar", "--sim-speed", PATROL_SPEED)  # fmt: skip
        runs.append(run)
    with ThreadPoolExecutor(args.jobs) as pool:
        done = list(pool.map(lambda run: run_patrol(run, PATROL_TIMEOUT_S), runs))
    tally = counts(done, plan)
    planned = sum(run.planned for run in done)
    print(f"going, seeds {args.seeds}: {tally['within']} of {planned} within 0.10 m and 3° "
          f"({100 * tally['within'] / planned:.1f} %), {tally['false arrival']} false, "
          f"{tally['heading off']} heading off, {tally['failed']} failed, "
          f"{tally['not run']} not run")  # fmt: skip
    for run in done:
        if run.problem:
            print(f"  seed {run.seed}: {run.problem}")
        misclaimed(run, plan, ("false arrival", "heading off", "failed"))


if __name__ == "__main__":
    main()
