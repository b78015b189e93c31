"""Benchmark: the CPU of building a map while driving (issue 29: "mapping keeps up with
the sensor, 5.5-10 scans a second, 360+ points each, using <= 20 % of a core").

A drive through a test building (tests/mapping/buildings.py) at 0.4 m/s, its scans ray
cast from the true poses (1 cm range noise, 12 m), given to the map builder at the poses
of an odometry that drifts (2 % distance error, 1.5 degrees a metre, no markers: the
worst case). The scans are cast first; only `add` is timed, as process time over the
simulated time the scans span: % of one core. In the same run, two peers:
- the same builder without scan matching (what the matcher costs, and what it buys);
- a plain per-beam update: a cv2.line of free cells per beam and the hit, on the same
  log-odds (what filling the scan's fan at once saves).
Each row gives the map's quality too: the fraction of occupied cells within 0.05 and
0.10 m of a true wall, the fraction of the walls' length seen, and the worst pose error.

Usage: python bench/mapping.py [--building wing|room|corridor] [--seed 1]
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.map_building import (
    _STATES,
    BOUND,
    HIT,
    MISS,
    MapBuilder,
    RangeScan,
)
from giraff_console.planning.scan_outline import usable_beams
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import (
    CORRIDOR_DRIVE,
    ROOM_DRIVE,
    WING_DRIVE,
    care_home_wing,
    drifted,
    drive,
    furnished_room,
    long_corridor,
    score,
    sweeps,
)

BUILDINGS = {
    "wing": (care_home_wing, WING_DRIVE),
    "room": (furnished_room, ROOM_DRIVE),
    "corridor": (long_corridor, CORRIDOR_DRIVE),
}
# (scans a second, beams a scan): an RPLIDAR A1's usual sweep, and a faster, denser one.
SENSORS = [(5.5, 360), (10.0, 400)]


class PerBeamGrid:
    """The peer: the same log-odds, a cv2.line of misses per beam, then the hits, on a
    fixed grid over the building and 13 m round it (no growth, no matching; hits the
    drift carries off it are dropped, the lines clipped)."""

    def __init__(self, walls: np.ndarray, resolution: float = 0.05) -> None:
        self.resolution = resolution
        self.left = float(walls[:, [0, 2]].min()) - 13
        self.bottom = float(walls[:, [1, 3]].min()) - 13
        cols = math.ceil((float(walls[:, [0, 2]].max()) + 13 - self.left) / resolution)
        rows = math.ceil((float(walls[:, [1, 3]].max()) + 13 - self.bottom) / resolution)
        self.odds = np.zeros((rows, cols), dtype=np.int16)

    def add(self, pose: Pose, scan: RangeScan, stamp: float) -> Pose:
        distance, bearing, hit = usable_beams(scan.beams, scan.range_max)
        rows = self.odds.shape[0]
        angle = pose.heading + bearing
        u = (pose.x + distance * np.cos(angle) - self.left) / self.resolution
        v = rows - (pose.y + distance * np.sin(angle) - self.bottom) / self.resolution
        start = (int((pose.x - self.left) / self.resolution),
                 int(rows - (pose.y - self.bottom) / self.resolution))  # fmt: skip
        delta = np.zeros_like(self.odds)
        for end in zip(u.astype(int).tolist(), v.astype(int).tolist(), strict=True):
            cv2.line(delta, start, end, MISS)
        rows_at, cols_at = v[hit].astype(int), u[hit].astype(int)
        on = (rows_at >= 0) & (rows_at < rows) & (cols_at >= 0) & (cols_at < self.odds.shape[1])
        delta[rows_at[on], cols_at[on]] = HIT
        np.add(self.odds, delta, out=self.odds)
        np.clip(self.odds, -BOUND, BOUND, out=self.odds)
        return pose

    def grid(self) -> OccupancyGrid:
        return OccupancyGrid(_STATES[self.odds + BOUND], self.resolution, (self.left, self.bottom))


def run(walls: np.ndarray, route: list, rate: float, beams: int, seed: int) -> list[tuple]:
    truth = drive(route, rate)
    poses = drifted(truth, 0.02, 1.5)
    scans = sweeps(walls, truth, beams, seed)
    seconds = len(scans) / rate
    rows = []
    peers = {
        "builder, matching": lambda: MapBuilder(match_scans=True),
        "builder, no matching": lambda: MapBuilder(match_scans=False),
        "per-beam cv2.line": lambda: PerBeamGrid(walls),
    }
    for name, make in peers.items():
        builder = make()
        used, costs = [], []
        for k, (pose, scan) in enumerate(zip(poses, scans, strict=True)):
            started = time.process_time()
            found = builder.add(pose, scan, k / rate)
            costs.append(time.process_time() - started)
            used.append(found if isinstance(found, Pose) else found.pose)
        worst = max(math.dist((p.x, p.y), (t.x, t.y)) for p, t in zip(used, truth, strict=True))
        quality = score(builder.grid(), walls)
        rows.append((f"{rate:g}/s x {beams}", name, 100 * sum(costs) / seconds,
                     1000 * float(np.median(costs)), 1000 * float(np.percentile(costs, 95)),
                     quality.near_05, quality.near_10, quality.seen, worst))  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--building", choices=sorted(BUILDINGS), default="wing")
    parser.add_argument("--seed", type=int, default=1)
    options = parser.parse_args()
    make, route = BUILDINGS[options.building]
    walls = make()
    machine = platform.processor() or platform.machine()
    print(f"mapping: {options.building}, {machine}, Python {platform.python_version()}, "
          f"drift 2 % and 1.5 deg/m, seed {options.seed}")  # fmt: skip
    header = ("sensor", "variant", "% core", "ms p50", "ms p95", "<=5cm", "<=10cm", "seen",
              "worst m")  # fmt: skip
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for rate, beams in SENSORS:
        for row in run(walls, route, rate, beams, options.seed):
            sensor, name, core, p50, p95, near_05, near_10, seen, worst = row
            print(f"| {sensor} | {name} | {core:.1f} | {p50:.2f} | {p95:.2f} | {near_05:.3f} "
                  f"| {near_10:.3f} | {seen:.3f} | {worst:.2f} |")  # fmt: skip


if __name__ == "__main__":
    main()
