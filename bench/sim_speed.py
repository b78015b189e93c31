"""Benchmark: how much faster than real time `go` runs on the simulator with its markers,
at `--sim-speed inf` on one core (issue 25, item 7), and whether the sightings are as good.

Timing: `giraff-console go kitchen --sim --sim-speed inf --imperfect --seed 3 --faults
off --json` in the example care home, each process pinned to one core (`taskset -c`),
three ways, interleaved round by round so that other load on the machine falls on all:
- whole frames: the synthetic camera draws all of every frame and the eye looks through
  all of it, ten times a second (the code path before issue 25);
- now: the camera draws only round the markers, and the eye looks only where markers
  can be, takes no frame when there is nothing to look for, and searches the whole
  frame once a second and after each turn (sim/marker_windows.py,
  robot/marker_search.py);
- no landmarks (`--no-landmarks`): no camera at all, the floor under the other two.
The figure is CPU time (user + system) of the pinned process, which other work on the
machine stretches far less than wall time; wall time beside it. "x real time" is the
simulated travel (the run's `duration_s`) over each. The eye's own counts come from the
child process: frames taken, looked through whole, and left untaken.

Accuracy: the same frames (a walk towards the plan's markers, from 1 to 5 m, to either
side and turned a little) seen both ways: the whole picture searched whole, and the
picture drawn round the markers searched where an estimate 3 cm and 1 degree off
predicts them. Each sighting's distance, bearing and facing error against the truth.

Figures on a 2-core Xeon shared with other work, medians of 3, CPU time (x real time):
at a load average of 2.5, whole frames 21.9 s (5.6x), now 6.2 s (20.1x), no landmarks
2.0 s (62.6x); at 3.5, 23.8 s (5.2x), 6.9 s (18.0x), 2.3 s (54.0x). The 296 sightings
of the accuracy walk are the same both ways, to the last bit.

Usage: python bench/sim_speed.py [--rounds 3] [--cpu 0] [--frames 300] [--no-timing]
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

GO = ["go", "kitchen", "--sim", "--sim-speed", "inf", "--imperfect", "--seed", "3",
      "--faults", "off", "--json"]  # fmt: skip
MODES = {"whole frames": [], "now": [], "no landmarks": ["--no-landmarks"]}
EYE_TAG = "sim_speed eye: "
EXAMPLE = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"


@dataclass
class Timing:
    cpu_s: list[float] = field(default_factory=list)
    wall_s: list[float] = field(default_factory=list)
    travel_s: float = math.nan
    eye: dict | None = None


def child(mode: str, argv: list[str]) -> int:
    """One `go` in this process, as `giraff-console` runs it; "whole frames" has the eye
    built as before issue 25. The eye's counts go to stderr at the end."""
    from giraff_console.robot.last_stop import SIGNALS

    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)  # as launch.py, before any thread
    from giraff_console.runtime import sim_site

    built = []
    eye = sim_site.SimulatedSite.eye

    @functools.wraps(eye)
    def counted(self, *args, **kwargs):
        made = eye(self, *args, whole_frames=mode == "whole frames", **kwargs)
        built.append(made)
        return made

    sim_site.SimulatedSite.eye = counted  # type: ignore[method-assign]
    from giraff_console.cli.main import main

    sys.argv = ["giraff-console", *argv]
    try:
        return main()
    finally:
        if built and built[0] is not None:
            print(EYE_TAG + json.dumps(built[0].cost()), file=sys.stderr)


def time_one(mode: str, cpu: str | None) -> tuple[float, float, float, dict | None]:
    """CPU seconds, wall seconds, simulated travel and the eye's counts of one run."""
    pin = ["taskset", "-c", cpu] if cpu is not None and shutil.which("taskset") else []
    command = [*pin, sys.executable, __file__, "--child", mode, "--", *GO, *MODES[mode]]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    # Without markers nothing can confirm the arrival: by the odometry alone it is
    # arrived_unverified, exit 3 (issue 25), and that is the floor the others stand on.
    unverified_ok = mode == "no landmarks"
    if result.returncode not in ((0, 3) if unverified_ok else (0,)) or not lines:
        raise SystemExit(f"{mode}: exit {result.returncode}: {result.stderr[-500:]}")
    report = json.loads(lines[-1])
    reached = ("arrived", "arrived_unverified") if unverified_ok else ("arrived",)
    if report.get("outcome") not in reached:
        raise SystemExit(f"{mode}: did not arrive: {report}")
    eye = [json.loads(line.removeprefix(EYE_TAG)) for line in result.stderr.splitlines()
           if line.startswith(EYE_TAG)]  # fmt: skip
    return cpu_s, wall, float(report["duration_s"]), eye[0] if eye else None


def timing(rounds: int, cpu: str | None) -> None:
    load = os.getloadavg()
    print(f"go kitchen --sim-speed inf, pinned to CPU {cpu}, {rounds} rounds; load average "
          f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} of {os.cpu_count()} cores")  # fmt: skip
    timings = {mode: Timing() for mode in MODES}
    for _ in range(rounds):
        for mode, found in timings.items():
            cpu_s, wall_s, found.travel_s, found.eye = time_one(mode, cpu)
            found.cpu_s.append(cpu_s)
            found.wall_s.append(wall_s)
    print(f"{'':<14}{'CPU s':>8}{'wall s':>8}{'x real (CPU)':>14}{'x real (wall)':>15}"
          f"{'travel s':>10}   eye frames: taken / whole / untaken")  # fmt: skip
    for mode, found in timings.items():
        cpu_s, wall_s = statistics.median(found.cpu_s), statistics.median(found.wall_s)
        eye = found.eye
        counts = "-" if eye is None else (
            f"{eye['frames']} / {eye.get('whole_frames', eye['frames'])} / "
            f"{eye.get('untaken_frames', 0)}"
        )  # fmt: skip
        print(f"{mode:<14}{cpu_s:>8.2f}{wall_s:>8.2f}{found.travel_s / cpu_s:>14.1f}"
              f"{found.travel_s / wall_s:>15.1f}{found.travel_s:>10.1f}   {counts}")  # fmt: skip
    load = os.getloadavg()
    print(f"(medians of {rounds}; load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})")


class Estimated:
    """What the eye's search reads of the localisation: an estimate off the truth."""

    def __init__(self, markers: dict) -> None:
        self.markers = markers
        self.now = None

    def estimate(self):
        return self.now


def walk(world, frames: int, rng: np.random.Generator) -> list:
    """Poses 1 to 5 m in front of the plan's markers, to either side and turned."""
    from giraff_console.sim.drive import TruePose

    poses = []
    for i in range(frames):
        marker = world.markers[(i * 7) % len(world.markers)]
        away = rng.uniform(1.0, 5.0)
        aside = rng.uniform(-0.4, 0.4) * away
        nx, ny = math.cos(marker.facing), math.sin(marker.facing)
        x = marker.x + nx * away - ny * aside
        y = marker.y + ny * away + nx * aside
        look = math.atan2(marker.y - y, marker.x - x) + rng.uniform(-0.35, 0.35)
        poses.append(TruePose(x, y, look))
    return poses


def compare(frames: int) -> dict:
    """Each way's sightings' errors (distance, bearing, facing), and how many of the
    sightings both made are identical."""
    import cv2

    from giraff_console.camera.markers import CameraIntrinsics
    from giraff_console.planning.floorplan import load_floorplan
    from giraff_console.planning.landmarks import marker_detector, marker_poses
    from giraff_console.robot.localisation import Estimate
    from giraff_console.robot.marker_eye import grey_of
    from giraff_console.robot.marker_search import Building, MarkerSearch
    from giraff_console.robot.odometry import Pose
    from giraff_console.runtime.sim_site import building_walls, plan_world
    from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
    from giraff_console.sim.marker_windows import MarkerWindows

    plan = load_floorplan(EXAMPLE)
    landmarks = plan.landmarks
    assert landmarks is not None
    camera = WorldCamera(plan_world(plan))
    windows = MarkerWindows(camera)

    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        known = camera.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)

    whole, regional = marker_detector(landmarks, intrinsics), marker_detector(landmarks, intrinsics)
    localisation = Estimated(marker_poses(plan))
    walls = np.array([(w.a, w.b) for w in building_walls(plan)], dtype=float).reshape(-1, 2, 2)
    building = Building(CAMERA_HEIGHT_M, {m.id: m.height for m in landmarks.markers}, walls)
    search = MarkerSearch(localisation, regional, building)  # type: ignore[arg-type]
    rng = np.random.default_rng(25)
    truth = {m.id: m for m in camera.world.markers}
    rows: dict = {"whole frames": [], "now": [], "same": 0}
    for pose in walk(camera.world, frames, rng):
        off = Pose(pose.x + rng.normal(0, 0.03), pose.y + rng.normal(0, 0.03),
                   pose.heading + rng.normal(0, math.radians(1)))  # fmt: skip
        covariance = ((0.03**2, 0, 0), (0, 0.03**2, 0), (0, 0, math.radians(1) ** 2))
        localisation.now = Estimate(off, off, covariance, 0.03, math.radians(1),
                                    (0.03, 0.03, 0.0), True, True)  # fmt: skip
        grey = cv2.cvtColor(camera.render(pose, 800, 600), cv2.COLOR_BGR2GRAY)
        before = whole.detect(grey)
        regions = search.regions(800, 600)
        wanted = None if regions is None else [(r.left, r.top, r.right, r.bottom) for r in regions]
        image = windows.render(pose, 800, 600, wanted)
        after = regional.detect(grey_of(image, regions), math.nan, regions)
        search.seen(after)
        for name, sightings in (("whole frames", before), ("now", after)):
            for s in sightings:
                # The marker in the robot's frame, from the true pose.
                m = truth[s.id]
                dx, dy = m.x - pose.x, m.y - pose.y
                c, n = math.cos(pose.heading), math.sin(pose.heading)
                x, y = c * dx + n * dy, -n * dx + c * dy
                rows[name].append((
                    s.distance_m - math.hypot(x, y),
                    _wrap(s.bearing_rad - math.atan2(y, x)),
                    _wrap(s.facing_rad - (m.facing - pose.heading)),
                ))  # fmt: skip
        mine = {s.id: s for s in after}
        rows["same"] += sum(
            1 for s in before if s.id in mine
            and np.array_equal(s.corners, mine[s.id].corners)
            and (s.distance_m, s.bearing_rad, s.facing_rad)
            == (mine[s.id].distance_m, mine[s.id].bearing_rad, mine[s.id].facing_rad)
        )  # fmt: skip
    return rows


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def accuracy(frames: int) -> None:
    """Sightings of the same frames, the whole way and the new, against the truth."""
    rows = compare(frames)
    print(f"\nsightings of {frames} frames walking towards the markers, against the truth")
    print(f"{'':<14}{'found':>6} | {'distance cm':^15} | {'bearing °':^15} | {'facing °':^15}")
    print(f"{'':<14}{'':>6} | {'median':>7}{'p95':>8} | {'median':>7}{'p95':>8} | "
          f"{'median':>7}{'p95':>8}")  # fmt: skip
    for name, errors in rows.items():
        if name == "same":
            continue
        cells = []
        for scale, column in ((100, 0), (180 / math.pi, 1), (180 / math.pi, 2)):
            values = np.abs(np.array([e[column] for e in errors])) * scale
            values = values[np.isfinite(values)]
            median, p95 = np.percentile(values, [50, 95]) if len(values) else (math.nan,) * 2
            cells.append(f"{median:>7.2f}{p95:>8.2f}")
        print(f"{name:<14}{len(errors):>6} | " + " | ".join(cells))
    print(f"sightings identical in both (corners, distance, bearing, facing): {rows['same']}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cpu", default="0", help="the core to pin each run to")
    parser.add_argument("--frames", type=int, default=300, help="frames for the accuracy")
    parser.add_argument("--no-timing", action="store_true")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args, rest = parser.parse_known_args()
    if args.child is not None:
        return child(args.child, [a for a in rest if a != "--"])
    if not args.no_timing:
        timing(args.rounds, args.cpu)
    if args.frames:
        accuracy(args.frames)
    return 0


if __name__ == "__main__":
    sys.exit(main())
