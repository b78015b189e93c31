"""Buildings of our own making for the mapping tests, a ray caster for their scans, a
drive through them with an odometry that drifts, and a score of a map against them.

A building is its walls as line segments (x1, y1, x2, y2), metres: exact for the ray
caster and for the score alike (a wall drawn as a grid would put its own cells' error
into both). Furniture is boxes of walls, as a scanner at knee height sees a bed or a
table's apron.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import cv2
import numpy as np

from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.robot.odometry import Pose

Walls = np.ndarray  # (S, 4): x1, y1, x2, y2


def box(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, ...]]:
    return [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]


def wall(x0: float, y0: float, x1: float, y1: float,
         doors: Sequence[tuple[float, float]] = ()) -> list[tuple[float, ...]]:  # fmt: skip
    """A straight wall with door gaps, each (distance from its start, width)."""
    length = math.hypot(x1 - x0, y1 - y0)
    ux, uy = (x1 - x0) / length, (y1 - y0) / length
    pieces, at = [], 0.0
    for start, width in sorted(doors):
        pieces.append((at, start))
        at = start + width
    pieces.append((at, length))
    return [(x0 + ux * a, y0 + uy * a, x0 + ux * b, y0 + uy * b) for a, b in pieces if b > a]


def care_home_wing() -> Walls:
    """A corridor 16 x 2 m with four 4 x 4 m rooms each side, a door into each, a bed and a
    wardrobe in the north rooms, a table in the south ones."""
    doors = [(4 * k + 1.5, 0.9) for k in range(4)]
    walls = wall(0, 0, 16, 0, doors) + wall(0, 2, 16, 2, doors)
    walls += [(0, -4, 0, 6), (16, -4, 16, 6), (0, 6, 16, 6), (0, -4, 16, -4)]
    for k in range(1, 4):
        walls += [(4 * k, 2, 4 * k, 6), (4 * k, -4, 4 * k, 0)]
    walls += [(0, 0, 0, 2)]
    for k in range(4):
        walls += box(4 * k + 0.2, 4.0, 4 * k + 1.2, 5.8)  # a bed against the far wall
        walls += box(4 * k + 3.0, 5.4, 4 * k + 3.8, 5.8)  # a wardrobe
        walls += box(4 * k + 1.4, -2.8, 4 * k + 2.6, -2.0)  # a table
    return np.array(walls, dtype=np.float64)


def long_corridor(length: float = 30.0) -> Walls:
    """A bare corridor 2 m wide, closed at both ends."""
    return np.array(box(0, 0, length, 2), dtype=np.float64)


def furnished_room() -> Walls:
    """A day room 8 x 6 m: sofas, tables, a piano, a door."""
    walls = [*wall(0, 0, 8, 0, [(3.5, 1.0)]), (8, 0, 8, 6), (8, 6, 0, 6), (0, 6, 0, 0)]
    walls += box(0.3, 4.8, 2.5, 5.7) + box(5.5, 0.3, 7.7, 1.1)  # sofas
    walls += box(3.0, 3.0, 4.2, 3.8) + box(1.0, 1.2, 1.8, 2.0)  # tables
    walls += box(6.4, 4.4, 7.7, 5.7)  # a piano
    return np.array(walls, dtype=np.float64)


def turned(walls: Walls, angle: float, about: tuple[float, float] = (0.0, 0.0)) -> Walls:
    """`walls` turned by `angle` about the point `about`."""
    c, s = math.cos(angle), math.sin(angle)
    x1, y1, x2, y2 = walls.T - np.array([*about, *about])[:, None]
    return np.column_stack([c * x1 - s * y1, s * x1 + c * y1, c * x2 - s * y2,
                            s * x2 + c * y2]) + np.array([*about, *about])  # fmt: skip


def turned_poses(poses: Sequence[Pose], angle: float) -> list[Pose]:
    """`poses` turned by `angle` about the origin, as `turned` turns walls."""
    c, s = math.cos(angle), math.sin(angle)
    return [Pose(c * p.x - s * p.y, s * p.x + c * p.y, p.heading + angle) for p in poses]


@dataclass(frozen=True)
class Sweep:
    """One scan, as a range sensor's reader gives it (planning/map_building.RangeScan)."""

    range_max: float
    beams: tuple[tuple[float, float], ...]


def ray_cast(walls: Walls, pose: Pose, bearings: np.ndarray, range_max: float,
             noise_m: float = 0.0, rng: np.random.Generator | None = None) -> Sweep:  # fmt: skip
    """The scan a sensor at `pose` takes of `walls`: every beam against every wall at
    once, the nearest crossing in range, inf past it; Gaussian range noise `noise_m`."""
    angle = pose.heading + bearings
    dx, dy = np.cos(angle)[:, None], np.sin(angle)[:, None]
    ex, ey = walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1]
    wx, wy = walls[:, 0] - pose.x, walls[:, 1] - pose.y
    across = dx * ey - dy * ex  # (N, S): zero for a beam along a wall
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = (wx * ey - wy * ex) / across
        along = (wx * dy - wy * dx) / across
    crossing = (np.abs(across) > 1e-12) & (along >= 0) & (along <= 1) & (reach > 1e-9)
    distance = np.where(crossing, reach, np.inf).min(axis=1)
    if noise_m and rng is not None:
        distance = distance + rng.normal(0.0, noise_m, distance.shape)
    distance[~(distance <= range_max)] = np.inf
    return Sweep(range_max, tuple(zip(distance.tolist(), bearings.tolist(), strict=True)))


def drive(waypoints: Sequence[tuple[float, float]], rate: float, speed: float = 0.4,
          turn_rate: float = math.radians(60)) -> list[Pose]:  # fmt: skip
    """The true poses, `rate` times a second, of a robot that turns on the spot towards
    each waypoint in turn and drives straight to it."""
    pieces: list[tuple[Pose, float, float, float]] = []  # start, seconds, speed, turn rate
    x, y = waypoints[0]
    heading = math.atan2(waypoints[1][1] - y, waypoints[1][0] - x)
    for nx, ny in waypoints[1:]:
        turn = math.remainder(math.atan2(ny - y, nx - x) - heading, math.tau)
        pieces.append((Pose(x, y, heading), abs(turn) / turn_rate, 0.0,
                       math.copysign(turn_rate, turn)))  # fmt: skip
        heading += turn
        length = math.hypot(nx - x, ny - y)
        pieces.append((Pose(x, y, heading), length / speed, speed, 0.0))
        x, y = nx, ny
    poses, clock, step = [], 0.0, 1.0 / rate
    for start, seconds, v, w in pieces:
        while clock < seconds:
            poses.append(Pose(start.x + v * clock * math.cos(start.heading),
                              start.y + v * clock * math.sin(start.heading),
                              start.heading + w * clock))  # fmt: skip
            clock += step
        clock -= seconds
    return poses


def drifted(poses: Sequence[Pose], distance_error: float, drift_deg_per_m: float,
            turn_error: float = 0.01) -> list[Pose]:  # fmt: skip
    """The poses an odometry with these errors integrates from the true ones: each step
    `distance_error` too long, turns `turn_error` too large, and the heading creeping
    `drift_deg_per_m` for every metre driven."""
    out = [poses[0]]
    x, y, heading = poses[0].x, poses[0].y, poses[0].heading
    for before, after in pairwise(poses):
        forward = (after.x - before.x) * math.cos(before.heading) + (after.y - before.y) * math.sin(
            before.heading
        )
        turn = math.remainder(after.heading - before.heading, math.tau)
        turn = turn * (1 + turn_error) + math.radians(drift_deg_per_m) * abs(forward)
        heading += turn / 2
        x += forward * (1 + distance_error) * math.cos(heading)
        y += forward * (1 + distance_error) * math.sin(heading)
        heading += turn / 2
        out.append(Pose(x, y, heading))
    return out


@dataclass(frozen=True)
class MapScore:
    near_05: float  # the fraction of occupied cells whose centre is within 0.05 m of a wall
    near_10: float  # ... within 0.10 m
    seen: float  # the fraction of the walls' length with an occupied cell within 0.10 m
    occupied: int


def score(grid: OccupancyGrid, walls: Walls) -> MapScore:
    """How well a map's occupied cells fall on the true walls, and how much of the
    walls they show."""
    rows, cols = np.nonzero(grid.cells == OCCUPIED)
    height = grid.cells.shape[0]
    px = grid.origin[0] + (cols + 0.5) * grid.resolution
    py = grid.origin[1] + (height - rows - 0.5) * grid.resolution
    nearest = _to_walls(px, py, walls)
    samples = []
    for x0, y0, x1, y1 in walls:
        count = max(2, math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.05))
        t = np.linspace(0, 1, count)
        samples.append(np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0)]))
    sx, sy = np.concatenate(samples).T
    free = (grid.cells != OCCUPIED).astype(np.uint8)
    to_occupied = cv2.distanceTransform(free, cv2.DIST_L2, 5) * grid.resolution
    col = np.floor((sx - grid.origin[0]) / grid.resolution).astype(int)
    row = height - 1 - np.floor((sy - grid.origin[1]) / grid.resolution).astype(int)
    inside = (row >= 0) & (row < height) & (col >= 0) & (col < grid.cells.shape[1])
    seen = np.zeros(len(sx), dtype=bool)
    seen[inside] = to_occupied[row[inside], col[inside]] <= 0.10
    count = len(px)
    return MapScore(float(np.mean(nearest <= 0.05)) if count else 0.0,
                    float(np.mean(nearest <= 0.10)) if count else 0.0,
                    float(np.mean(seen)), count)  # fmt: skip


def _to_walls(px: np.ndarray, py: np.ndarray, walls: Walls) -> np.ndarray:
    """Each point's distance to the nearest wall."""
    ax, ay = walls[:, 0], walls[:, 1]
    ex, ey = walls[:, 2] - ax, walls[:, 3] - ay
    t = ((px[:, None] - ax) * ex + (py[:, None] - ay) * ey) / (ex * ex + ey * ey)
    t = np.clip(t, 0, 1)
    return np.hypot(ax + t * ex - px[:, None], ay + t * ey - py[:, None]).min(axis=1)


def bearings(count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` beams evenly round the circle from a random start, as a spinning sensor's
    sweeps start wherever the turn happens to be."""
    return (rng.uniform(0, math.tau) + np.arange(count) * math.tau / count) % math.tau - math.pi


def sweeps(walls: Walls, truth: Sequence[Pose], beams: int, seed: int,
           noise_m: float = 0.01, range_max: float = 12.0) -> list[Sweep]:  # fmt: skip
    """The scans an RPLIDAR-like sensor (`beams` a turn, 1 cm of range noise, 12 m)
    takes at each true pose."""
    rng = np.random.default_rng(seed)
    return [ray_cast(walls, pose, bearings(beams, rng), range_max, noise_m, rng) for pose in truth]


# A drive through the care-home wing: along the corridor, into two rooms north and one
# south, to the far end and back.
WING_DRIVE = [(1, 1), (5.95, 1), (5.95, 3.6), (5.95, 1), (9.95, 1), (9.95, -1.5), (9.95, 1),
              (15, 1), (13.95, 1), (13.95, 3.4), (13.95, 1), (2, 1)]  # fmt: skip
# Round the furnished room, in at its door and among the furniture (half a metre from
# it: the sensor is at the robot's centre).
ROOM_DRIVE = [(4, -1.5), (4, 0.5), (4, 2.2), (6.5, 2.5), (6, 4.3), (1.5, 4.3), (1.5, 2.6),
              (2.2, 2.6), (3.8, 0.7), (4, -1)]  # fmt: skip
# Along the bare corridor and back.
CORRIDOR_DRIVE = [(1, 1), (29, 1), (2, 1)]
