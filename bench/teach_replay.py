"""Benchmark: a mapping drive recorded once, replayed through the map builder in seconds
(issue 29: to score each change to the mapping on a whole drive, not a toy one).

`record`: the teaching drive of bench/teach_building.py (the simulator put in the
building, `--imperfect`, the simulated lidar through the real reader, the scripted
operator marking each room), with everything the mapping run was given written to a
file: each tick's filter pose and heading sigma with the simulator's true pose beside
it, each revolution as read, and each `mark`'s time.

`replay`: those ticks, revolutions and marks fed, in their order, through a
MappingRun laid in on the caller's thread (no revolution is dropped, so the score is
the same every time), the plan written as `map save` writes it; said: the rooms the
plan has against the real rooms, the map's occupied cells within 0.05 and 0.10 m of
the truth, and the map pose's error against the true pose (median, 95th percentile,
worst, heading's too), with the builder's process time per revolution.

`--perturb N` replays each file N times more, its filter poses moved by a millimetre
(Gaussian, seeds 1..N): a replay's rooms and scores swing that much under such a
change (a wall kept or lost by a cell), so a change to the drawing is judged on all of
them, not on one.

Usage: python bench/teach_replay.py record --building home [--map-seed 1] --to FILE
       python bench/teach_replay.py replay [--loops] [--perturb N] FILE [FILE ...]
"""

from __future__ import annotations

import argparse
import math
import pickle
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.any_building import machine, source
from bench.teach_building import DRIVE_TIMEOUT_S, judge_map, judge_plan
from giraff_console.lidar import SIMULATED_LIDAR
from giraff_console.lidar.scan import LidarScan
from giraff_console.missions.mapping import MappingRun
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.map_building import MapBuilder
from giraff_console.planning.mapped_plan import MappedPlanError, write_mapped_plan
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import Telemetry
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.settings import Settings
from tests.buildings.console import put_up_markers
from tests.teaching import BUILDINGS
from tests.teaching.flat import unmapped_plan
from tests.teaching.operator import Operator, tour

PERTURB_M = 0.001  # `--perturb`'s move of each filter pose (m, one sigma each way)


@dataclass
class Recording:
    """One drive, as the mapping run was given it."""

    building: str
    map_seed: int
    start: Pose
    # Each tick: its time, the filter's pose, the heading's sigma, the true pose.
    ticks: list[tuple[float, Pose, float, Pose]] = field(default_factory=list)
    scans: list[LidarScan] = field(default_factory=list)
    marks: list[tuple[float, str]] = field(default_factory=list)


def record(building: str, seed: int, to: Path, sim_speed: float = 1.0) -> None:
    folder = Path(tempfile.mkdtemp(prefix="teach-replay-"))
    teaching = BUILDINGS[building](folder)
    put_up_markers(teaching.truth)
    truth = load_floorplan(teaching.truth)
    options = RobotOptions(floorplan=unmapped_plan(folder, teaching.dock),
                           sim_building=teaching.truth, sim_speed=sim_speed, imperfect_seed=seed,
                           faults=False, lidar=SIMULATED_LIDAR)  # fmt: skip
    with Robot(options, Settings(), teaching.truth) as robot:
        robot.start()
        service, control = robot.service, robot.service.building_map.control
        started = service.execute(c.StartMapping())
        assert started.ok, started.text
        run = service.building_map.run
        assert run is not None and service.building_map.sensor is not None
        kept = Recording(building, seed, run.start)

        def heard(event: object) -> None:
            if isinstance(event, Telemetry):
                sigma = event.estimate.sigma_heading if event.estimate is not None else 0.0
                true = robot.true_pose()
                assert true is not None
                kept.ticks.append((control.clock.now(), event.pose, sigma, true))

        execute = service.execute

        def marking(command: c.Request) -> object:
            if isinstance(command, c.Mark):
                kept.marks.append((control.clock.now(), command.place))
            return execute(command)

        control.subscribe(heard)
        service.building_map.sensor.subscribe(kept.scans.append)
        service.execute = marking  # type: ignore[method-assign]
        drive = Operator(robot, DRIVE_TIMEOUT_S).drive(tour(truth, teaching.tour))
        service.execute = execute  # type: ignore[method-assign]
        control.unsubscribe(heard)
    to.write_bytes(pickle.dumps(kept))
    span = kept.scans[-1].taken_at - kept.scans[0].taken_at if len(kept.scans) > 1 else 0.0
    rate = (len(kept.scans) - 1) / span if span > 0 else 0.0
    print(f"recorded {building} seed {seed}: {drive.metres:.1f} m in {drive.seconds:.0f} s, "
          f"{len(kept.ticks)} ticks, {len(kept.scans)} revolutions ({rate:.2f} a second of "
          f"the loop's clock; the sensor gives 5.5), marked {drive.marked}; {to}")  # fmt: skip


def _pose_errors(laid: list, poses: list, true_t: np.ndarray, true_xyh: np.ndarray) -> dict:
    """Each laid revolution's pose against the true pose at its stamp."""
    errors = []
    for scan, mapped in zip(laid, poses, strict=True):
        t = scan.stamp
        tx = np.interp(t, true_t, true_xyh[:, 0])
        ty = np.interp(t, true_t, true_xyh[:, 1])
        th = np.interp(t, true_t, true_xyh[:, 2])
        turn = math.remainder(mapped.heading - th, math.tau)
        errors.append((math.hypot(mapped.x - tx, mapped.y - ty), abs(math.degrees(turn))))
    err = np.array(errors) if errors else np.zeros((1, 2))
    return {
        "pos_median_m": float(np.median(err[:, 0])),
        "pos_p95_m": float(np.percentile(err[:, 0], 95)),
        "pos_worst_m": float(err[:, 0].max()),
        "head_median_deg": float(np.median(err[:, 1])),
        "head_p95_deg": float(np.percentile(err[:, 1], 95)),
        "head_worst_deg": float(err[:, 1].max()),
    }


def perturbed(kept: Recording, seed: int) -> Recording:
    """`kept` with each tick's filter pose moved by a millimetre (Gaussian, `seed`)."""
    rng = np.random.default_rng(seed)
    moved = rng.normal(0.0, PERTURB_M, (len(kept.ticks), 2))
    ticks = [
        (t, Pose(pose.x + dx, pose.y + dy, pose.heading), sigma, true)
        for (t, pose, sigma, true), (dx, dy) in zip(kept.ticks, moved, strict=True)
    ]
    return replace(kept, ticks=ticks)


def replay(path: Path, quiet: bool = False, loops: bool = False, perturb_seed: int = 0) -> dict:
    """The drive in `path` replayed, its poses moved by `perturbed` if `perturb_seed`."""
    kept: Recording = pickle.loads(path.read_bytes())
    if perturb_seed:
        kept = perturbed(kept, perturb_seed)
    folder = Path(tempfile.mkdtemp(prefix="teach-replay-"))
    teaching = BUILDINGS[kept.building](folder)
    truth = load_floorplan(teaching.truth)
    run = MappingRun(MapBuilder(keep=True), lambda text: None, kept.start)
    run.close()  # laid in below, on this thread, each in its turn
    events: list[tuple[float, int, object]] = [(tick[0], 0, tick) for tick in kept.ticks]
    events += [(scan.taken_at, 1, scan) for scan in kept.scans]
    events += [(t, 2, name) for t, name in kept.marks]
    events.sort(key=lambda e: (e[0], e[1]))
    true_t = np.array([tick[0] for tick in kept.ticks])
    true_xyh = np.array([(tick[3].x, tick[3].y, tick[3].heading) for tick in kept.ticks])
    true_xyh[:, 2] = np.unwrap(true_xyh[:, 2])
    cpu = 0.0
    last_pose = kept.start
    for _t, kind, what in events:
        if kind == 0:
            tick = what
            last_pose = tick[1]
            run.pose(tick[0], tick[1], tick[2])
        elif kind == 1:
            began = time.process_time()
            run.lay_in(what)  # type: ignore[arg-type]
            cpu += time.process_time() - began
        else:
            run.mark(what, last_pose)  # type: ignore[arg-type]
    out = folder / f"{kept.building}-mapped"
    status = run.status()
    report: dict = {"building": kept.building, "laid_in": status.scans,
                    "turning": status.turning,
                    "broken": status.broken,
                    "revolutions": len(kept.scans),
                    "ms_per_rev": 1000 * cpu / max(1, status.scans)}  # fmt: skip
    laid = list(run.builder.laid)
    poses = [scan.pose for scan in laid]
    if loops:
        began = time.process_time()
        closed = run.close_loops()
        assert closed is not None
        report |= {"loop_s": time.process_time() - began, "keyframes": closed.keyframes,
                   "loops": closed.loops, "squared": closed.squared,
                   "outliers": closed.outliers}  # fmt: skip
        poses = closed.poses
    grid = run.grid()
    marks = [(m.name, m.at) for m in run.status().marks]
    try:
        made = write_mapped_plan(grid, marks, kept.start, out)
        report |= judge_plan(made.plan, truth, teaching) | judge_map(out, truth)
        report["plan"] = str(made.plan.path)
    except MappedPlanError as error:
        report["error"] = str(error)
    report |= _pose_errors(laid, poses, true_t, true_xyh)
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    rec = sub.add_parser("record")
    rec.add_argument("--building", choices=sorted(BUILDINGS), default="home")
    rec.add_argument("--map-seed", type=int, default=1)
    rec.add_argument("--to", type=Path, required=True)
    rec.add_argument(
        "--sim-speed",
        type=float,
        default=1.0,
        help="the simulator's clock against the wall's (1: the sensor's own pace)",
    )
    rep = sub.add_parser("replay")
    rep.add_argument("files", type=Path, nargs="+")
    rep.add_argument("--loops", action="store_true", help="close loops before saving")
    rep.add_argument("--perturb", type=int, default=0, metavar="N",
                     help="each file replayed N times more, its poses moved by 1 mm")  # fmt: skip
    args = parser.parse_args()
    print(f"machine: {machine()}; source: {source()}", flush=True)
    if args.what == "record":
        record(args.building, args.map_seed, args.to, args.sim_speed)
        return
    if args.perturb < 0:
        parser.error(f"--perturb: a number of replays, 0 or more, not {args.perturb}")
    for path in args.files:
        for seed in range(args.perturb + 1):
            report(path, seed, replay(path, loops=args.loops, perturb_seed=seed))


def report(path: Path, seed: int, r: dict) -> None:
    """One replay's line."""
    moved = f" moved {seed}" if seed else ""
    print(f"{path.name}{moved}: {r.get('rooms', '-')} rooms of {r.get('real_rooms', '-')} "
          f"(named right {r.get('named_right', '-')}/{r.get('marked_rooms', '-')}), "
          f"map {100 * r.get('within_5cm', 0):.0f} % within 0.05 m, "
          f"{100 * r.get('within_10cm', 0):.0f} % within 0.10 m "
          f"({r.get('occupied_cells', 0)} cells); pose error median "
          f"{r['pos_median_m']:.3f} m p95 {r['pos_p95_m']:.3f} worst {r['pos_worst_m']:.2f}, "
          f"heading median {r['head_median_deg']:.1f}° p95 {r['head_p95_deg']:.1f}° worst "
          f"{r['head_worst_deg']:.0f}°; {r['laid_in']} of {r['revolutions']} laid in "
          f"({r['turning']} turning, {r['broken']} with samples lost), "
          f"{r['ms_per_rev']:.1f} ms each"
          + (f"; loops: {r['keyframes']} keyframes, {r['loops']} closures, "
             f"{r['squared']} squared, {r['outliers']} left out, {r['loop_s']:.1f} s"
             if "loops" in r else "")
          + (f"; {r['error']}" if "error" in r else "")
          + (f"; {r['plan']}" if "plan" in r else ""), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
