"""A path the board can drive: lines, arcs and clothoids, and turns in place (§2.7).

"Turning while moving has some interesting mathematical properties (the curves the robot
follow are apparently clothoid segments)" (§2.7): in curved motion the board ramps its
gear ratio linearly with distance (A.2.3, `vgr` per metre) and the curvature is
vg / 0.2495 1/m, so a ramp drives a clothoid and a held ratio an arc. Every piece of
path here is one of those: a `Segment` along which the curvature changes linearly with
arc length, from `k0` to `k1` (equal for a line or an arc). Where the robot must turn
on the spot (at the start, at the end, where no curve fits) the path has a `Rotation`.

Curvature is positive to the left (counter-clockwise), like the heading; the board's
gear ratio is positive to the right, so vg = -curvature * 0.2495 (`gear_of`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.robot.odometry import Pose

# Clothoid poses are integrated with Simpson's rule in steps of at most this much path.
_STEP_M = 0.01


def gear_of(curvature: float) -> float:
    """The board's gear ratio for a curvature (positive left): vg = -k * 0.2495."""
    return -curvature * TURN_RADIUS_M


def wrap(angle: float) -> float:
    """An angle in (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2 * math.pi)


@dataclass(frozen=True)
class Segment:
    """Path along which the curvature goes linearly from k0 to k1 over `length` metres."""

    start: Pose
    length: float
    k0: float = 0.0
    k1: float = 0.0

    @property
    def sharpness(self) -> float:
        """dk/ds, 1/m^2: zero for lines and arcs."""
        return (self.k1 - self.k0) / self.length if self.length > 0 else 0.0

    @property
    def end(self) -> Pose:
        return self.pose_at(self.length)

    def curvature_at(self, s: float) -> float:
        return self.k0 + self.sharpness * min(max(s, 0.0), self.length)

    def pose_at(self, s: float) -> Pose:
        """The pose after `s` metres of this segment (0 <= s <= length)."""
        x0, y0, h0 = self.start.x, self.start.y, self.start.heading
        if self.sharpness == 0.0:
            k = self.k0
            if abs(k) < 1e-12:
                return Pose(x0 + s * math.cos(h0), y0 + s * math.sin(h0), h0)
            h = h0 + k * s
            return Pose(x0 + (math.sin(h) - math.sin(h0)) / k,
                        y0 - (math.cos(h) - math.cos(h0)) / k, h)  # fmt: skip
        if s <= 0:
            return self.start
        steps = 2 * max(1, math.ceil(s / (2 * _STEP_M)))
        t = np.linspace(0.0, s, steps + 1)
        angles = h0 + self.k0 * t + self.sharpness * t * t / 2
        weights = np.ones(steps + 1)
        weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
        scale = s / (3 * steps)
        return Pose(x0 + scale * float(weights @ np.cos(angles)),
                    y0 + scale * float(weights @ np.sin(angles)), float(angles[-1]))  # fmt: skip


@dataclass(frozen=True)
class Rotation:
    """Turning on the spot at `at` by `angle` radians (positive left)."""

    at: Pose
    angle: float

    @property
    def end(self) -> Pose:
        return Pose(self.at.x, self.at.y, self.at.heading + self.angle)


@dataclass(frozen=True)
class Drive:
    """Segments driven in one go, from standstill to standstill."""

    segments: tuple[Segment, ...]

    @property
    def length(self) -> float:
        return sum(segment.length for segment in self.segments)

    @property
    def start(self) -> Pose:
        return self.segments[0].start

    @property
    def end(self) -> Pose:
        return self.segments[-1].end

    def locate(self, s: float) -> tuple[Segment, float]:
        """The segment `s` metres along the drive falls in, and how far into it."""
        for segment in self.segments:
            if s <= segment.length:
                return segment, max(s, 0.0)
            s -= segment.length
        last = self.segments[-1]
        return last, last.length

    def pose_at(self, s: float) -> Pose:
        segment, into = self.locate(s)
        return segment.pose_at(into)

    def curvature_at(self, s: float) -> float:
        segment, into = self.locate(s)
        return segment.curvature_at(into)


@dataclass(frozen=True)
class Reverse:
    """Backing straight up `length` metres from `start`, the robot facing the way it
    faces there: how a robot that has touched something gets clear of it the way it
    came (missions/recovery.py). `pose_at(s)` is where it is after backing `s` metres."""

    start: Pose
    length: float

    @property
    def end(self) -> Pose:
        return self.pose_at(self.length)

    def pose_at(self, s: float) -> Pose:
        back = min(max(s, 0.0), self.length)
        h = self.start.heading
        return Pose(self.start.x - back * math.cos(h), self.start.y - back * math.sin(h), h)

    def ahead(self) -> Drive:
        """The same line driven forwards, which has the same speed profile."""
        return Drive((Segment(self.end, self.length),))


Section = Drive | Rotation | Reverse
