"""A simulated range finder on the robot's front: distances to what is in the way.

The thesis would add "an infrared laser range finder ... to minimize the risk of
crashing into things" (§6): with one, obstacles "are typically not too hard to detect"
(§2.4), and a LIDAR sweeps its beam across what is in front of it (§2.2.5). This one
sweeps `rays` beams evenly over its field of view, centred on the heading, and reports
the nearest hit of each within range. A beam that meets nothing within range says so, as
a laser scan does (ROS REP 117: +inf, "no objects detected within range"): that it saw
free space is what lets the console forget a box that has been taken away.

It senses only the `Surroundings` (boxes, closed doors), not the building's walls: the
floor plan already has those, and what the console needs from the sensor is what the
plan does not know (§2.1: blueprints leave out "furniture or people").

Readings are in the robot's frame. The console must turn them into map points with its
own pose estimate (odometry, §2.3): it never sees the simulator's true pose, so an
obstacle lands on its map where the console believes the robot saw it, errors and all,
as it would with a real sensor. `scan_points` uses the true pose, for tests only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import Surroundings, cast_rays


@dataclass(frozen=True)
class Scan:
    """One sweep, as a LIDAR's scan message has it: each beam's (distance m, bearing
    rad, positive to the left), from right to left; `math.inf` where the beam met
    nothing within `range_max`."""

    range_max: float
    beams: tuple[tuple[float, float], ...]
    # It senses only what is in the way, never the building's walls (missions/lookout.py),
    # and is read on the tick.
    sees_walls: ClassVar[bool] = False
    taken_at: ClassVar[None] = None
    whole: ClassVar[bool] = True  # cast at once

    @property
    def hits(self) -> list[tuple[float, float]]:
        """The beams that met something."""
        return [beam for beam in self.beams if math.isfinite(beam[0])]


class SimRangeFinder:
    """A planar scanner at the robot's centre; thread-safe, since it keeps no state."""

    def __init__(
        self,
        pose: Callable[[], TruePose],
        surroundings: Surroundings,
        range_m: float = 1.5,
        fov_deg: float = 70.0,
        rays: int = 36,
    ) -> None:
        if rays < 1 or not range_m > 0 or not 0 < fov_deg <= 360:
            raise ValueError("a range finder needs rays, a range and a field of view")
        self.pose = pose
        self.surroundings = surroundings
        self.range_m = range_m
        half = math.radians(fov_deg) / 2
        # The first and last beams at the edges of the field of view, as a LIDAR's
        # angle_min and angle_max; one beam looks straight ahead.
        self.bearings = np.linspace(-half, half, rays) if rays > 1 else np.zeros(1)
        self.bearings.setflags(write=False)

    def readings(self) -> Scan:
        """Every beam of one sweep, those that met nothing within range at inf."""
        _, distance = self._scan()
        beams = zip(distance.tolist(), self.bearings.tolist(), strict=True)
        return Scan(self.range_m, tuple(beams))

    def scan_points(self) -> list[tuple[float, float]]:
        """The hits as (x, y) on the map, placed with the true pose: tests only."""
        pose, distance = self._scan()
        hit = np.isfinite(distance)
        angle = pose.heading + self.bearings[hit]
        x = pose.x + distance[hit] * np.cos(angle)
        y = pose.y + distance[hit] * np.sin(angle)
        return list(zip(x.tolist(), y.tolist(), strict=True))

    def _scan(self) -> tuple[TruePose, np.ndarray]:
        """One sweep, each beam's distance (inf beyond range): the pose and the
        surroundings are read once, so that every beam starts from the same place and
        sees the same things."""
        pose = self.pose()
        starts, ends = self.surroundings.segments()
        if not len(starts):
            return pose, np.full(len(self.bearings), np.inf)
        angle = pose.heading + self.bearings
        t, _ = cast_rays(pose.x, pose.y, np.cos(angle), np.sin(angle), starts, ends)
        distance = t.min(axis=1)
        return pose, np.where(distance <= self.range_m, distance, np.inf)
