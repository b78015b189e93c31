"""Benchmark: `go` (clothoid turns, jerk-limited) against the thesis's way of moving.

The thesis's console moved in straight trapezoid moves the board ramps itself, turning
on the spot between them, because a curve could not be ended without a stop or a jerk
(§3.2.1.2-§3.2.1.4, A.2). `go` shapes the planned path into clothoid turns and drives
it on a jerk-limited profile (missions/go_to.py); missions/waypoint_drive.py does it the
thesis's way on the same planned path. This drives both from the example care home's
dock to every room and measures, in one run:

- planning: the wall time of GoTo's construction (planning, shaping, profiles) and of
  the peer's (planning); each run plans on a fresh navigator, so no leg measured by an
  earlier run is reused;
- travel: virtual seconds until the mission ends, and its ratio to GoTo's
  `time_optimal` (the jerk-limited optimum along GoTo's shaped path);
- stops on the way, the arrival error against the room's point and heading (from the
  simulator's true pose), the largest jerk and the gear ratio jumps. GoTo's report
  gives the jerk of its commanded speeds; for both, the jerk is also taken from the
  speed the board reports each tick (20 Hz, so a step in acceleration a shows as at
  most a / 0.05 s).

Each run gets a fresh simulated board on a virtual clock and a fresh control loop,
stepped at 20 Hz, the robot placed at the plan's start. `--imperfect` turns on the
simulator's imperfections (missed distances, caster drift, stalls, ESTOP), seeded per
room, the same seed for both methods. `--door-speed` changes how fast `go` may pass a
doorway (0.25 m/s by default): the thesis's way knows no doors, and drives through them
at full speed.

`--twm` instead compares curves sent as separate `set`s (the thesis's board) and as one
Giraff-X `set twm` per change: commands and bytes per tick, gear-ratio steps (bench/twm.py).

Usage: python bench/motion.py [--rooms a,b,c] [--imperfect] [--seed S] [--door-speed V]
       python bench/motion.py --twm [--rooms ROOM]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import giraff_console
from giraff_console.link import BoardLink
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.waypoint_drive import WaypointDrive
from giraff_console.motion.path import wrap
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.floorplan import FloorPlan, load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.loop_events import LoopEvent
from giraff_console.robot.mission import Mission, MissionEnd, Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import rotation_wheel_speed
from giraff_console.robot.telemetry import Telemetry
from giraff_console.robot.teleop import Teleop
from giraff_console.sim.drive import TruePose

EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"
TICK_S = 0.05  # the control loop's 20 Hz
# No go on the example takes half of this; a run still going then has gone wrong.
TIMEOUT_S = 600.0
# A tick-to-tick change of the gear ratio beyond this, where none was asked for, is a
# jump (the peer drives straight only, so any change is one).
GEAR_JUMP = 1e-3

MakeMission = Callable[[Navigator, str, Callable[[], Pose]], Mission]


@dataclass
class Run:
    """How one go went."""

    end: MissionEnd
    plan_ms: float
    travel_s: float
    stops: int
    error_mm: float
    heading_deg: float | None  # None: the room asks for no heading
    jerk: float | None  # of the commanded speeds (GoTo's report); None for the peer
    board_jerk: float  # from the speeds the board reported
    gear_jumps: int
    mission: Mission


def finished(run: Run) -> bool:
    """The drive got to its end (arrived, confirmed or not; the peer judges nothing)."""
    return run.end.outcome.arrived or run.end.outcome is Outcome.DONE


def board_jerk(samples: list[tuple[float, float]]) -> float:
    """The largest second difference of the reported speed, m/s^3."""
    jerk = 0.0
    for (t0, v0), (t1, v1), (t2, v2) in zip(samples, samples[1:], samples[2:], strict=False):
        if t1 <= t0 or t2 <= t1:
            continue
        change = (v2 - v1) / (t2 - t1) - (v1 - v0) / (t1 - t0)
        jerk = max(jerk, abs(change) / ((t2 - t0) / 2))
    return jerk


def drive(plan: FloorPlan, room: str, make: MakeMission, url: str) -> Run:
    """One go from the plan's start to `room`, on a fresh board and control loop."""
    link = BoardLink.open(url)
    clock, board = link.port.clock, link.port.board
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    navigator = Navigator(plan, walls_of(plan))
    start = navigator.start_pose
    assert start is not None, "the example plan has a start room"
    control.odometry.reset(start)
    board.place(TruePose(start.x, start.y, start.heading))
    control.tick()  # connects: a stop, then settings within the limits

    began = time.perf_counter()
    mission = make(navigator, room, lambda: control.odometry.pose)
    plan_ms = (time.perf_counter() - began) * 1e3

    speeds: list[tuple[float, float]] = []
    gears: list[float] = []

    def watch(event: LoopEvent) -> None:
        if not isinstance(event, Telemetry) or event.state is None:
            return
        state, r = event.state, event.board_r
        speed = rotation_wheel_speed(state, r) if r is not None and r <= 0 else state.speed
        speeds.append((state.received_at, abs(speed or 0.0)))
        gears.append(state.cvg)

    control.subscribe(watch)
    ended: list[MissionEnd] = []
    started = clock.now()
    control.run_mission(mission, ended.append)
    while not ended:
        if clock.now() - started > TIMEOUT_S:
            control.stop_mission(Outcome.FAILED, f"timed out after {TIMEOUT_S:g} s")
        control.tick()
        clock.advance(TICK_S)
    travel = clock.now() - TICK_S - started  # the tick that ended it ran before the advance
    control.shutdown()

    truth, goal = board.true_pose, plan.rooms[room]
    heading = None
    if goal.heading is not None:
        heading = math.degrees(abs(wrap(truth.heading - math.radians(goal.heading))))
    error = math.dist((truth.x, truth.y), goal.at) * 1e3
    if isinstance(mission, GoTo):
        report = mission.report(ended[0])
        return Run(ended[0], plan_ms, travel, len(report.stops), error, heading, report.max_jerk,
                   board_jerk(speeds), report.gear_jumps, mission)  # fmt: skip
    assert isinstance(mission, WaypointDrive)
    jumps = sum(abs(b - a) > GEAR_JUMP for a, b in pairwise(gears))
    return Run(ended[0], plan_ms, travel, len(mission.stops), error, heading, None,
               board_jerk(speeds), jumps, mission)  # fmt: skip


def cells(run: Run, optimal: float) -> str:
    heading = "-" if run.heading_deg is None else f"{run.heading_deg:.2f}"
    jerk = "" if run.jerk is None else f"{run.jerk:>6.2f}"
    return (f"{run.plan_ms:>8.0f}{run.travel_s:>9.1f}{run.travel_s / optimal:>7.3f}"
            f"{run.stops:>6}{run.error_mm:>9.1f}{heading:>7}{jerk}{run.board_jerk:>7.2f}"
            f"{run.gear_jumps:>6}")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rooms", help="comma-separated rooms (default: every room)")
    parser.add_argument("--imperfect", action="store_true", help="simulator imperfections on")
    parser.add_argument("--seed", type=int, default=1, help="first seed with --imperfect")
    parser.add_argument("--door-speed", type=float, default=MotionLimits().door_speed,
                        help="GoTo's speed through doorways, m/s (default %(default)s); "
                             "the thesis's way knows no doors")  # fmt: skip
    parser.add_argument("--twm", action="store_true",
                        help="compare separate sets with Giraff-X's twm (bench/twm.py), "
                             "driving `go` to the first of --rooms (default lobby)")  # fmt: skip
    args = parser.parse_args()
    if args.twm:
        from twm import compare  # bench/twm.py, beside this script

        compare(args.rooms.split(",")[0] if args.rooms else "lobby")
        return
    plan = load_floorplan(EXAMPLE)
    rooms = sorted(room for room in plan.rooms if room != plan.start)
    if args.rooms:
        rooms = args.rooms.split(",")
        unknown = [room for room in rooms if room not in plan.rooms]
        if unknown:
            parser.error(f"no such rooms: {', '.join(unknown)}")
    limits = MotionLimits(door_speed=args.door_speed)

    def go_to(navigator: Navigator, room: str, pose: Callable[[], Pose]) -> Mission:
        return GoTo(navigator, room, pose, tick=TICK_S, limits=limits)

    def waypoints(navigator: Navigator, room: str, pose: Callable[[], Pose]) -> Mission:
        return WaypointDrive.to_room(navigator, room, pose, limits)

    print(f"giraff-console {giraff_console.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} cores")  # fmt: skip
    board = "imperfect board" if args.imperfect else "ideal board"
    print(f"from {plan.start} to {len(rooms)} rooms, {board}, 20 Hz virtual clock; v "
          f"{limits.v_max} m/s (doorways {limits.door_speed}), a {limits.a_max} m/s², "
          f"go's jerk {limits.j_max} m/s³")  # fmt: skip
    columns = f"{'plan ms':>8}{'travel s':>9}{'ratio':>7}{'stops':>6}{'err mm':>9}{'err °':>7}"
    print(f"{'':<15}{'':>7} | {'go: clothoid turns, jerk-limited':<59} | "
          f"thesis: stop, turn on the spot, straight")  # fmt: skip
    print(f"{'room':<15}{'opt s':>7} | {columns}{'jerk':>6}{'board':>7}{'jumps':>6} | "
          f"{columns}{'board':>7}{'jumps':>6}")  # fmt: skip
    results: list[tuple[str, float, Run, Run]] = []
    began = time.perf_counter()
    for index, room in enumerate(rooms):
        url = "giraff-sim://?clock=virtual"
        if args.imperfect:
            url += f"&imperfect=1&seed={args.seed + index}"
        ours = drive(plan, room, go_to, url)
        peer = drive(plan, room, waypoints, url)
        assert isinstance(ours.mission, GoTo)
        optimal = ours.mission.time_optimal
        results.append((room, optimal, ours, peer))
        notes = "".join(f"  {name}: {run.end.why}" for name, run in (("go", ours), ("thesis", peer))
                        if not finished(run))  # fmt: skip
        print(f"{room:<15}{optimal:>7.1f} | {cells(ours, optimal)} | {cells(peer, optimal)}{notes}")
    summarise(results, time.perf_counter() - began)


def summarise(results: list[tuple[str, float, Run, Run]], seconds: float) -> None:
    """Both methods side by side: medians, worst cases and totals over the rooms both
    reached (with --imperfect a stall or an ESTOP can end a run on the way)."""
    reached = [result for result in results if finished(result[2]) and finished(result[3])]
    print(f"{'summary':<18}{'go':>22}{'thesis':>22}   over the {len(reached)} rooms both reached")
    columns = {"go": summary(results, reached, 2), "thesis": summary(results, reached, 3)}
    for label in columns["go"]:
        print(f"{label:<18}{columns['go'][label]:>22}{columns['thesis'][label]:>22}")
    pairs = [(ours, peer) for _, _, ours, peer in reached]
    within = sum(ours.travel_s <= 1.15 * optimal for _, optimal, ours, _ in reached)
    faster = sum(ours.travel_s < peer.travel_s for ours, peer in pairs)
    fewer = sum(ours.stops < peer.stops for ours, peer in pairs)
    print(f"go: within 1.15 x time_optimal in {within}/{len(reached)} rooms, faster than the "
          f"thesis's way in {faster}, fewer stops in {fewer}; "
          f"benchmark {seconds:.0f} s")  # fmt: skip


def summary(results: list[tuple[str, float, Run, Run]], reached: list[tuple[str, float, Run, Run]],
            which: int) -> dict[str, str]:  # fmt: skip
    """One method's column of the summary: which = 2 for go, 3 for the thesis's way."""
    arrived = sum(finished(result[which]) for result in results)  # type: ignore[arg-type]
    runs: list[Run] = [result[which] for result in reached]  # type: ignore[misc]
    if not runs:
        return {"arrived": f"{arrived}/{len(results)}"}
    ratios = [run.travel_s / result[1] for run, result in zip(runs, reached, strict=True)]
    worst = max(range(len(runs)), key=ratios.__getitem__)
    headings = [run.heading_deg for run in runs if run.heading_deg is not None]
    return {
        "arrived": f"{arrived}/{len(results)}",
        "median plan ms": f"{statistics.median(run.plan_ms for run in runs):.0f}",
        "median travel s": f"{statistics.median(run.travel_s for run in runs):.1f}",
        "total travel s": f"{sum(run.travel_s for run in runs):.0f}",
        "median ratio": f"{statistics.median(ratios):.3f}",
        "worst ratio": f"{ratios[worst]:.3f} {reached[worst][0]}",
        "median stops": f"{statistics.median(run.stops for run in runs):g}",
        "total stops": f"{sum(run.stops for run in runs)}",
        "median error mm": f"{statistics.median(run.error_mm for run in runs):.1f}",
        "worst error mm": f"{max(run.error_mm for run in runs):.1f}",
        "worst heading °": f"{max(headings, default=0.0):.2f}",
        "worst board jerk": f"{max(run.board_jerk for run in runs):.2f}",
        "gear jumps": f"{sum(run.gear_jumps for run in runs)}",
    }


if __name__ == "__main__":
    main()
