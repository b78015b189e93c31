"""One revolution of the lidar as the robot sees it: beams from its centre, bearings
counter-clockwise.

The RPLIDAR's angles grow clockwise seen from above, 0 at the sensor's front
(protocol/rplidar.py); the robot's bearings grow counter-clockwise, 0 ahead, as ROS's
REP 103 has them and as missions/lookout.py reads them. The sensor may sit ahead of the
robot's centre (`forward_m`) and be turned (`yaw_rad`, counter-clockwise); a beam is
given from the robot's centre, so that the console places it with the robot's pose
alone. A sample that measured nothing (distance 0 or quality 0), or one outside the
sensor's range, is a beam that met nothing: +inf, as REP 117 has it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

# A move of the sensor's angle, between two samples that measured a distance, of more
# than this many usual steps for each sample read between them is samples lost: a
# sensor measures at an even pace (an A1 about every degree, an A3 every quarter), a
# reader that fell behind loses runs of them.
LOST_STEPS = 3.0


@dataclass(frozen=True)
class Mount:
    """Where the sensor sits on the robot: metres ahead of its centre, and turned
    counter-clockwise from its heading."""

    forward_m: float = 0.0
    yaw_rad: float = 0.0


@dataclass(frozen=True)
class LidarScan:
    """One revolution: each beam's (distance m, bearing rad, positive left) from the
    robot's centre, from right to left; inf where nothing was met within `range_max`.
    `taken_at`: when its last sample came (the reader's clock), for mapping."""

    range_max: float
    beams: tuple[tuple[float, float], ...]
    taken_at: float
    samples: int
    # Whether its samples swept the turn once with none lost (`whole_turn`): a reader
    # that fell behind loses samples, and what is left is a piece of a turn or two
    # turns run together, which may be looked at for obstacles but not fitted to a map.
    whole: bool = True
    # A lidar sees the building's walls as well as what is in the way (missions/lookout.py).
    sees_walls: ClassVar[bool] = True

    @property
    def hits(self) -> list[tuple[float, float]]:
        return [beam for beam in self.beams if math.isfinite(beam[0])]


def robot_beams(angle_deg: np.ndarray, distance_mm: np.ndarray, quality: np.ndarray,
                mount: Mount, range_min: float,
                range_max: float) -> tuple[tuple[float, float], ...]:  # fmt: skip
    """A revolution's samples as beams in the robot's frame, sorted by bearing."""
    distance = np.asarray(distance_mm, dtype=float) / 1000.0
    seen = (distance >= range_min) & (distance <= range_max) & (np.asarray(quality) > 0)
    sensor_bearing = mount.yaw_rad - np.radians(np.asarray(angle_deg, dtype=float))
    # Where each hit is, from the robot's centre; a miss keeps its sensor bearing.
    x = mount.forward_m + distance * np.cos(sensor_bearing)
    y = distance * np.sin(sensor_bearing)
    bearing = np.where(seen, np.arctan2(y, x), np.arctan2(np.sin(sensor_bearing),
                                                          np.cos(sensor_bearing)))  # fmt: skip
    reach = np.where(seen, np.hypot(x, y), np.inf)
    order = np.argsort(bearing, kind="stable")
    return tuple(zip(reach[order].tolist(), bearing[order].tolist(), strict=True))


def within(scan: LidarScan, range_m: float) -> LidarScan:
    """The scan as a sensor of `range_m` would give it: farther hits are beams that met
    nothing within range. The missions look for obstacles this far (motion.sensing_range),
    not across the whole building."""
    if range_m >= scan.range_max:
        return scan
    beams = tuple((d if d <= range_m else math.inf, b) for d, b in scan.beams)
    return LidarScan(range_m, beams, scan.taken_at, scan.samples, scan.whole)


def whole_turn(angle_deg: np.ndarray, measured: np.ndarray) -> bool:
    """Whether a revolution's samples, their angles in the order read (from its start
    flag), swept the turn once with none lost. Judged on the samples that measured a
    distance (`measured`): the sensor's own SDK takes the angle of one that did not for
    no angle. Between two of them the angle moves on by at most LOST_STEPS usual steps
    for each sample read, and back by no more than one (jitter; two turns run together,
    the start flag between them lost, go back by a whole turn); from the last round to
    the first, the same. A turn holds a fraction of a sample more or less than a whole
    number, so its last sample may end up to two steps short of the first's angle."""
    angles = np.asarray(angle_deg, dtype=float)
    index = np.flatnonzero(np.asarray(measured, dtype=bool))
    if len(index) < 2:
        return False
    # From the first, as the sensor turned: a first angle of 359.9 is followed by 0.3.
    swept = np.mod(angles[index] - angles[index[0]], 360.0)
    moved, read = np.diff(swept), np.diff(index)
    usual = float(np.median(moved / read))
    closing, closing_read = 360.0 - swept[-1], len(angles) - index[-1] + index[0]
    return bool(usual > 0 and np.all(moved >= -usual) and np.all(moved <= LOST_STEPS * usual * read)
                and closing <= LOST_STEPS * usual * closing_read)  # fmt: skip
