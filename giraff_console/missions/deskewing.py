"""A lidar's revolution as if taken all at once, from where the robot stood at its end
(issue 29).

A revolution is not a snapshot: the RPLIDAR sweeps its beams round one after another,
5.5 to 10 times a second, while the robot drives and turns. At 0.25 m/s the first beam
of a revolution is taken 4.5 cm back from its last; at 15 degrees a second, 2.7 degrees
turned. Drawn at one pose, the revolution's walls are bent and moved by that much,
and the scan matcher, fitting them to the walls drawn before, settles off by it: on the
teaching drives (bench/teach_replay.py) the map's pose was 0.20 m from the true one
(median) on the small flat and 0.34 m on the scanned home with every revolution at its
end's pose, 0.06 and 0.17 m with each beam put where it was seen from.

Each beam's moment is found from its bearing: the sensor sweeps clockwise (protocol/
rplidar.py), starting at its front, so a beam at bearing b (counter-clockwise, 0 ahead)
came a share ((-b) mod 2 pi) / 2 pi of the way through. The robot's motion over the
revolution is taken as steady (the filter's poses at its start and end), which it
nearly is over a fifth of a second. A sensor mounted turned (lidar/scan.py's Mount) starts
its sweep elsewhere; taking it at the front then puts a few beams at their neighbours'
moments, no worse than not deskewing at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from giraff_console.missions.lookout import Scan
from giraff_console.robot.odometry import Pose


@dataclass(frozen=True)
class DeskewedScan:
    """A revolution's beams from the robot's centre at its end: (distance m, bearing rad)
    rows, inf where nothing was met, as the map builder's RangeScan has them."""

    range_max: float
    beams: np.ndarray  # (N, 2)


def deskewed(scan: Scan, began: Pose, ended: Pose) -> DeskewedScan:
    """`scan`'s beams as seen from `ended`, the robot's pose at the revolution's end,
    each moved by the robot's motion from the moment it was taken; `began` is the pose a
    revolution earlier."""
    beams = np.array(scan.beams, dtype=float).reshape(-1, 2)
    if not len(beams):
        return DeskewedScan(scan.range_max, beams)
    distance, bearing = beams[:, 0], beams[:, 1]
    # The share of the revolution still to come when each beam was taken.
    left = 1.0 - np.mod(-bearing, math.tau) / math.tau
    # Where the robot stood at the start, in the frame of its end.
    c, s = math.cos(ended.heading), math.sin(ended.heading)
    east, north = began.x - ended.x, began.y - ended.y
    back_x, back_y = c * east + s * north, -s * east + c * north
    back_turn = math.remainder(began.heading - ended.heading, math.tau)
    seen = np.isfinite(distance)
    reach = np.where(seen, distance, 1.0)
    heading = bearing + left * back_turn
    x = left * back_x + reach * np.cos(heading)
    y = left * back_y + reach * np.sin(heading)
    # A beam that met nothing keeps only its direction.
    turned = np.arctan2(np.sin(heading), np.cos(heading))
    return DeskewedScan(scan.range_max, np.column_stack([
        np.where(seen, np.hypot(x, y), np.inf), np.where(seen, np.arctan2(y, x), turned),
    ]))  # fmt: skip
