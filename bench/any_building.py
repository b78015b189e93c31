"""Benchmark: does the robot arrive where it says it has, in buildings unlike the example
care home (issue 25, "Any building, a real robot")?

Three buildings of tests/buildings/, each brought in as a care home would bring it: an
Open-RMF import without outlines (rmf_clinic), a scan made a plan by `floorplan rooms`
(scanned_home: furniture, clutter, 0.8 m doors) and a hand-written plan of 39 walled
rooms (walled_wing). Each gets its markers from `floorplan landmarks` and must pass
`floorplan check`; a building whose markers cannot be placed is said so, and only its
dead reckoning is run.

For each building and seed, a patrol of 10 rooms (one from each of 10 parts of the
building, in a seeded order; a patrol is 10 `go`s in a row in one process) on the
simulator with its imperfections and without random faults, run as
`giraff-console patrol FILE --sim --sim-speed inf --json --imperfect --seed N --faults
off --floorplan PLAN`, with the markers and with `--no-landmarks` (dead reckoning). At
every stop the claim (`outcome == "arrived"` where the JSON has an outcome, else
`arrived`) is set against the true pose:
- within: claimed, and the truth within 0.10 m and 3° (the heading only where the room
  has one) of the goal: the issue asks for 98 % of the stops;
- false arrival: claimed, and the truth more than 0.10 m off: the issue asks for none;
- heading off: claimed, within 0.10 m, but more than 3° off the room's heading;
- failed: the stop's line claims no arrival (an arrival the JSON's outcome calls
  unverified included; the outcomes and reasons are listed, grouped);
- not run: no line for the stop (the patrol ended before it, or the process failed).
`--walled-patrol` also runs a patrol of three rounds through every room of walled_wing
(nearest first from the dock, and back) per seed, and says how many stops were reached,
which failed and why, and whether the patrol was abandoned (it stopped before its last
stop).

Usage: python bench/any_building.py [--buildings A,B] [--seeds 1-8] [--rooms 10]
       [--jobs 2] [--timeout S] [--walled-patrol] [--folder DIR] [--save FILE] [--quick]
Before: python bench/any_building.py --seeds 1-2 --jobs 1
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import random
import re
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import giraff_console
from bench.localisation import figures, tour
from giraff_console.planning.floorplan import FloorPlan, check_floorplan, load_floorplan
from giraff_console.planning.grid import FREE
from giraff_console.planning.route_planner import walls_of
from tests.buildings import BUILDINGS, put_up_markers

# Issue 25's bounds on a claimed arrival.
WITHIN_M, WITHIN_DEG = 0.10, 3.0
MARKERS, DEAD_RECKONING, WALLED_PATROL = "markers", "dead reckoning", "walled patrol"
WALLED = "walled_wing"


@dataclass
class Building:
    """A building made for the benchmark, and what became of its markers and checks."""

    name: str
    plan_path: Path | None = None
    plan: FloorPlan | None = None
    markers: int | None = None
    problem: str | None = None  # why it cannot be driven at all
    markers_problem: str | None = None  # why it has no markers

    def describe(self) -> str:
        """Rooms, doors, size, door widths and markers, on a line."""
        if self.plan is None:
            return f"{self.name}: NOT BUILT: {self.problem}"
        plan = self.plan
        widths = sorted(door.width for door in plan.doors)
        narrow = sum(width <= 0.8 + 1e-6 for width in widths)
        headings = sum(room.heading is not None for room in plan.rooms.values())
        outlines = sum(room.outline is not None for room in plan.rooms.values())
        markers = (f"{self.markers} markers" if self.markers is not None
                   else f"no markers ({self.markers_problem})")  # fmt: skip
        return (f"{self.name}: {len(plan.rooms)} rooms ({outlines} outlined, {headings} "
                f"with a heading), {len(plan.doors)} doors {widths[0]:.2f}-{widths[-1]:.2f} m "
                f"({narrow} of 0.8 m or less), floor {floor_size(plan)}, start "
                f"{plan.start}; {markers}")  # fmt: skip


@dataclass
class Run:
    """One patrol process: its stop lines and its last line."""

    building: str
    mode: str
    seed: int
    rooms: list[str]
    rounds: int
    command: list[str] = field(default_factory=list)
    stops: list[dict] = field(default_factory=list)
    summary: dict | None = None
    code: int | None = None
    wall_s: float = 0.0
    problem: str | None = None  # the process failed: usage error, timeout, crash

    @property
    def planned(self) -> int:
        return self.rounds * len(self.rooms)


def floor_size(plan: FloorPlan) -> str:
    """The free floor's extent, from the grid the robot plans on."""
    grid = walls_of(plan)
    if grid is None:
        return "no grid"
    rows, cols = np.nonzero(grid.cells == FREE)
    return (f"{(cols.max() - cols.min() + 1) * grid.resolution:.0f} m by "
            f"{(rows.max() - rows.min() + 1) * grid.resolution:.0f} m")  # fmt: skip


def build(name: str, folder: Path) -> Building:
    """The building made in `folder`, its markers put up and the plan checked; whatever
    fails is kept to report, never raised: the console's commands that make and check it
    are what the benchmark measures, and one building's failure says nothing of the
    others."""
    building = Building(name)
    (folder / name).mkdir(parents=True, exist_ok=True)
    try:
        path = BUILDINGS[name](folder / name)
        markers = put_up_markers(path)
        if not markers.placed:
            building.markers_problem = f"floorplan landmarks: {markers.said}"
        building.markers = markers.placed or None
        problems = check_floorplan(path)
        if problems:
            building.problem = "floorplan check: " + "; ".join(map(str, problems[:5]))
            return building
        building.plan_path, building.plan = path, load_floorplan(path)
    except Exception as error:  # reported with the building, as the docstring says
        building.problem = f"{type(error).__name__}: {error}"
    return building


def parts(plan: FloorPlan, count: int) -> list[list[str]]:
    """The rooms but the start in `count` parts of the building: round `count` rooms as
    far from each other as can be (the first the furthest from the start), each room in
    its nearest's part. The same for every seed."""
    rooms = sorted(room for room in plan.rooms if room != plan.start)
    at = {room: plan.rooms[room].at for room in rooms}
    here = plan.rooms[plan.start].at if plan.start else at[rooms[0]]
    centres = [max(rooms, key=lambda room: math.dist(here, at[room]))]
    while len(centres) < min(count, len(rooms)):
        centres.append(max(rooms, key=lambda room: min(math.dist(at[room], at[centre])
                                                       for centre in centres)))  # fmt: skip
    grouped: dict[str, list[str]] = {centre: [] for centre in centres}
    for room in rooms:
        grouped[min(centres, key=lambda centre: math.dist(at[room], at[centre]))].append(room)
    return list(grouped.values())


def patrol_rooms(plan: FloorPlan, seed: int, count: int) -> list[str]:
    """`count` rooms for seed `seed`'s patrol: one from each part of the building, in a
    seeded order, so that the legs cross it."""
    rng = random.Random(seed)
    chosen = [rng.choice(part) for part in parts(plan, count)]
    rng.shuffle(chosen)
    return chosen


def patrol_command(patrol: Path, plan: Path, seed: int, *extra: str) -> list[str]:
    return [
        sys.executable, "-m", "giraff_console", "patrol", str(patrol), "--sim",
        "--sim-speed", "inf", "--json", "--imperfect", "--seed", str(seed), "--faults", "off",
        "--floorplan", str(plan), *extra,
    ]  # fmt: skip


def run_patrol(run: Run, timeout: float) -> Run:
    """Run the patrol process, keeping each JSON line as it comes, so that a process
    killed at its timeout (after an hour, say) keeps the stops it reached."""
    began = time.perf_counter()
    timed_out = threading.Event()
    with tempfile.TemporaryFile("w+") as errors:
        process = subprocess.Popen(run.command, stdout=subprocess.PIPE, stderr=errors,
                                   text=True)  # fmt: skip

        def kill() -> None:
            timed_out.set()
            process.kill()

        timer = threading.Timer(timeout, kill)
        timer.start()
        try:
            lines = [line for text in process.stdout or () if (line := _json(text))]
        finally:
            timer.cancel()
            process.kill()  # no more than a no-op once it has ended
            process.wait()
        errors.seek(0)
        tail = errors.read().strip().splitlines()[-3:]
    run.wall_s = time.perf_counter() - began
    run.code = process.returncode
    if lines and "patrol" in lines[-1]:
        run.summary = lines.pop()
    run.stops = lines
    if timed_out.is_set():
        run.problem = f"timed out after {timeout:.0f} s"
    elif run.code not in (0, 1) or run.summary is None:
        run.problem = f"exit {run.code}: {' / '.join(tail)}"
    return run


def _json(text: str) -> dict | None:
    """A line of the patrol's JSON, or None for anything else (a line cut off by a kill)."""
    if not text.startswith("{"):
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return None


def claimed(stop: dict) -> bool:
    """Whether the stop says the robot arrived: its `outcome` where it has one (an
    arrival not checked by a marker is no claim to be there), else `arrived`."""
    return stop["outcome"] == "arrived" if "outcome" in stop else bool(stop["arrived"])


def judged(stop: dict, plan: FloorPlan) -> str:
    """What the stop was: within, false arrival, heading off or failed (the module's
    docstring says which is which)."""
    if not claimed(stop):
        return "failed"
    if stop["error_m"] > WITHIN_M:
        return "false arrival"
    if has_heading(stop, plan) and stop["heading_error_deg"] > WITHIN_DEG:
        return "heading off"
    return "within"


def has_heading(stop: dict, plan: FloorPlan) -> bool:
    room = plan.rooms.get(stop["room"] or "")
    return room is not None and room.heading is not None


def why_group(why: str) -> str:
    """A reason with its numbers taken out, so that alike reasons count together."""
    return re.sub(r"-?\d+(\.\d+)?", "#", why)


def counts(runs: list[Run], plan: FloorPlan) -> Counter:
    tally: Counter = Counter()
    for run in runs:
        tally.update(judged(stop, plan) for stop in run.stops)
        tally["not run"] += run.planned - len(run.stops)
    return tally


def table(runs: list[Run], buildings: dict[str, Building]) -> None:
    """A row per building and mode: the stops of every seed together."""
    print(f"{'building':<14}{'mode':<16}{'stops':>6}{'within':>8}{'%':>7}{'false':>7}"
          f"{'hdg>3°':>7}{'failed':>7}{'not run':>8} | {'error m (claimed)':^21} | "
          f"{'heading ° (claimed)':^21} | {'max jerk':>8}")  # fmt: skip
    print(f"{'':<80} | {'median':>7}{'p95':>7}{'worst':>7} | {'median':>7}{'p95':>7}"
          f"{'worst':>7} |")  # fmt: skip
    for name, building in buildings.items():
        for mode in (MARKERS, DEAD_RECKONING):
            mine = [run for run in runs if run.building == name and run.mode == mode]
            if building.plan is None or not mine:
                why = building.problem if building.plan is None else building.markers_problem
                print(f"{name:<14}{mode:<16}  not run: {why}")
                continue
            plan = building.plan
            tally = counts(mine, plan)
            planned = sum(run.planned for run in mine)
            made = [stop for run in mine for stop in run.stops if claimed(stop)]
            headings = [s["heading_error_deg"] for s in made if has_heading(s, plan)]
            jerks = [s["max_jerk"] for run in mine for s in run.stops
                     if s.get("max_jerk") is not None]  # fmt: skip
            jerk = f"{max(jerks):>8.2f}" if jerks else f"{'-':>8}"
            errors = figures([stop["error_m"] for stop in made])
            print(f"{name:<14}{mode:<16}{planned:>6}{tally['within']:>8}"
                  f"{100 * tally['within'] / planned:>6.1f}%{tally['false arrival']:>7}"
                  f"{tally['heading off']:>7}{tally['failed']:>7}{tally['not run']:>8} | "
                  f"{errors} | {figures(headings)} | {jerk}")  # fmt: skip


def details(runs: list[Run], buildings: dict[str, Building]) -> None:
    """The issue's verdict per building and mode, the reasons stops failed (grouped), the
    outcomes where the JSON gives them, and processes that failed."""
    for name, building in buildings.items():
        for mode in (MARKERS, DEAD_RECKONING):
            mine = [run for run in runs if run.building == name and run.mode == mode]
            if building.plan is None or not mine:
                continue
            tally = counts(mine, building.plan)
            planned = sum(run.planned for run in mine)
            met = tally["within"] >= 0.98 * planned and tally["false arrival"] == 0
            verdict = "met" if met else "NOT met"
            print(f"{name}, {mode}: issue 25's bounds {verdict} ({tally['within']}/{planned} "
                  f"within, {tally['false arrival']} false)")  # fmt: skip
            stops = [stop for run in mine for stop in run.stops]
            reasons = Counter(why_group(f"{s.get('outcome', 'not arrived')}: {s['why']}")
                              for s in stops if not claimed(s))  # fmt: skip
            for why, count in reasons.most_common():
                print(f"    {count} x failed: {why}")
            for run in mine:
                misclaimed(run, building.plan, ("false arrival", "heading off"))
            outcomes = Counter(stop["outcome"] for stop in stops if "outcome" in stop)
            if outcomes:
                print(f"    outcomes: {dict(outcomes)}")
            for run in mine:
                if run.problem is not None:
                    print(f"    seed {run.seed}: FAILED: {run.problem}")


def walled_report(runs: list[Run], building: Building) -> None:
    """Per seed: the stops reached, those that failed and why, and whether the patrol
    was abandoned (stopped before its last stop)."""
    rounds = runs[0].rounds
    print(f"\n{WALLED_PATROL}: {len(runs[0].rooms)} stops a round, {rounds} "
          f"round{'s' if rounds != 1 else ''}")  # fmt: skip
    for run in sorted(runs, key=lambda run: run.seed):
        assert building.plan is not None
        tally = counts([run], building.plan)
        abandoned = run.summary is None or len(run.stops) < run.planned
        why = run.problem or (run.summary or {}).get("why")
        print(f"  seed {run.seed}: {len(run.stops)}/{run.planned} stops driven, "
              f"{sum(claimed(s) for s in run.stops)} reached ({tally['within']} within, "
              f"{tally['false arrival']} false), {tally['failed']} failed; "
              f"{'ABANDONED' if abandoned else 'went on to the end'} ({why}); "
              f"{run.wall_s / 60:.0f} min")  # fmt: skip
        misclaimed(run, building.plan, ("false arrival", "heading off", "failed"))


def misclaimed(run: Run, plan: FloorPlan, kinds: tuple[str, ...]) -> None:
    """A line for each stop of `run` judged one of `kinds`: where, and how far off the
    truth was, or why it failed."""
    for stop in run.stops:
        kind = judged(stop, plan)
        if kind not in kinds:
            continue
        how = stop["why"] if kind == "failed" else (
            f"the truth {stop['error_m']:.3f} m and {stop['heading_error_deg']:.1f}° off, "
            f"known to {stop['sigma_m']:.3f} m")  # fmt: skip
        print(f"    seed {run.seed}, round {stop['round']}, stop {stop['stop']} "
              f"({stop['room']}): {kind}: {how}")  # fmt: skip


def machine() -> str:
    """The machine the figures were taken on, and how busy it was."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        names = re.findall(r"model name\s*:\s*(.+)", cpuinfo.read_text())
        model = names[0] if names else model
    load = ", ".join(f"{value:.2f}" for value in os.getloadavg())
    return (f"{platform.node()}: {model}, {os.cpu_count()} cores; load average {load}; "
            f"Python {platform.python_version()}")  # fmt: skip


def source() -> str:
    """The commit measured, and whether the console's code had changes not in it: the
    figures are of the working tree."""
    root = Path(__file__).resolve().parent.parent

    def git(*args: str) -> str:
        done = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True,
                              timeout=30)  # fmt: skip
        return done.stdout.strip()

    changed = git("status", "--porcelain", "--", "giraff_console")
    return git("rev-parse", "--short", "HEAD") + (" with changes to giraff_console" if changed
                                                   else "")  # fmt: skip


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(part) for part in text.split("-"))
        return list(range(first, last + 1))
    return [int(part) for part in text.split(",")]


def jobs_for(buildings: dict[str, Building], seeds: list[int], args: argparse.Namespace,
             folder: Path) -> list[Run]:  # fmt: skip
    """A run for each building, mode and seed, and the walled patrols if asked."""
    runs = []
    for name, building in buildings.items():
        if building.plan is None or name not in args.buildings:
            continue
        for seed in seeds:
            rooms = patrol_rooms(building.plan, seed, args.rooms)
            patrol = write_patrol(folder / f"{name}-{seed}.patrol.yaml", rooms, 1)
            modes = [(DEAD_RECKONING, ("--no-landmarks",))]
            if building.markers:
                modes.insert(0, (MARKERS, ()))
            for mode, extra in modes:
                run = Run(name, mode, seed, rooms, 1)
                run.command = patrol_command(patrol, building.plan_path, seed, *extra)
                runs.append(run)
    walled = buildings.get(WALLED)
    if args.walled_patrol and walled is not None and walled.plan is not None:
        rooms = tour(walled.plan)[: 3 if args.quick else None]
        rounds = 1 if args.quick else 3
        patrol = write_patrol(folder / "walled-every-room.patrol.yaml", rooms, rounds)
        for seed in seeds:
            run = Run(WALLED, WALLED_PATROL, seed, rooms, rounds)
            run.command = patrol_command(patrol, walled.plan_path, seed)
            runs.append(run)
    return runs


def write_patrol(path: Path, rooms: list[str], rounds: int) -> Path:
    path.write_text(yaml.safe_dump({"rounds": rounds, "snapshots": False,
                                    "stops": [{"room": room} for room in rooms]}))  # fmt: skip
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buildings", default=",".join(BUILDINGS), metavar="A,B",
                        help="the buildings to drive, or none (default %(default)s)")  # fmt: skip
    parser.add_argument("--seeds", default="1-8", metavar="A-B|A,B,..",
                        help="imperfection seeds (default %(default)s)")  # fmt: skip
    parser.add_argument("--rooms", type=int, default=10, help="stops a patrol (default 10)")
    parser.add_argument("--jobs", type=int, default=2, help="processes at once (default 2)")
    parser.add_argument("--timeout", type=float, default=300.0, metavar="S",
                        help="seconds a patrol process may take for each of its stops "
                             "(default %(default)s)")  # fmt: skip
    parser.add_argument("--walled-patrol", action="store_true",
                        help="also patrol every room of walled_wing, three rounds")  # fmt: skip
    parser.add_argument("--folder", type=Path, metavar="DIR",
                        help="build the buildings and patrols here and keep them "
                             "(default: a temporary folder)")  # fmt: skip
    parser.add_argument("--save", type=Path, metavar="FILE", help="write every run as JSON")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: the first seed, three rooms (the walled patrol: "
                             "three rooms, one round)")  # fmt: skip
    args = parser.parse_args()
    args.buildings = [] if args.buildings == "none" else args.buildings.split(",")
    unknown = set(args.buildings) - set(BUILDINGS)
    if unknown:
        parser.error(f"no building {', '.join(sorted(unknown))} (there are "
                     f"{', '.join(BUILDINGS)})")  # fmt: skip
    seeds = seeds_of(args.seeds)[: 1 if args.quick else None]
    args.rooms = 3 if args.quick else args.rooms
    print(f"giraff-console {giraff_console.__version__} ({source()}) on {machine()}; "
          f"{args.jobs} at once")  # fmt: skip
    patrols = [f"{args.rooms} rooms in {', '.join(args.buildings)}"] if args.buildings else []
    if args.walled_patrol:
        patrols.append(f"3 rooms of {WALLED}, 1 round" if args.quick
                       else f"every room of {WALLED}, 3 rounds")  # fmt: skip
    print(f"patrols of {' and of '.join(patrols)}; seeds {', '.join(map(str, seeds))}; "
          f"--imperfect, --faults off; within: {WITHIN_M} m and {WITHIN_DEG}°",
          flush=True)  # fmt: skip
    began = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.folder or Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        wanted = set(args.buildings) | ({WALLED} if args.walled_patrol else set())
        buildings = {name: build(name, folder) for name in BUILDINGS if name in wanted}
        # Described while their grids are on disk: a temporary folder is gone at the end.
        described = {name: building.describe() for name, building in buildings.items()}
        for line in described.values():
            print(f"  {line}", flush=True)
        runs = jobs_for(buildings, seeds, args, folder)
        with ThreadPoolExecutor(args.jobs) as pool:
            futures = [pool.submit(run_patrol, run, args.timeout * run.planned) for run in runs]
            for future in as_completed(futures):
                run = future.result()
                reached = sum(claimed(stop) for stop in run.stops)
                print(f"  done: {run.building}, {run.mode}, seed {run.seed}: {reached}/"
                      f"{run.planned} claimed, {run.wall_s:.0f} s"
                      f"{'; ' + run.problem if run.problem else ''}", file=sys.stderr)  # fmt: skip
    print()
    go_runs = [run for run in runs if run.mode != WALLED_PATROL]
    if go_runs or args.buildings:
        table(go_runs, {name: buildings[name] for name in args.buildings})
        details(go_runs, {name: buildings[name] for name in args.buildings})
    walled_runs = [run for run in runs if run.mode == WALLED_PATROL]
    if walled_runs:
        walled_report(walled_runs, buildings[WALLED])
    print(f"benchmark {(time.perf_counter() - began) / 60:.0f} min; load average now "
          f"{', '.join(f'{value:.2f}' for value in os.getloadavg())}")  # fmt: skip
    if args.save is not None:
        saved = {"machine": machine(), "source": source(), "seeds": seeds,
                 "buildings": described,
                 "runs": [asdict(run) for run in runs]}  # fmt: skip
        args.save.write_text(json.dumps(saved, indent=1))


if __name__ == "__main__":
    main()
