"""Velocity profiles of one move: trapezoid, triangle and reversal (A.1, B.2 StartStraight).

A move starts at the current speed, ramps to the peak speed with constant acceleration,
cruises, and ramps down to stop at the target (Figure A.1). Short moves never reach the
peak and give a triangle. When a preempting target lies inside the braking distance,
the board brakes through zero and comes back (the thesis's SIM_OVERSHOOT_FIX, which the
real board does too). Slowing down to a lower peak speed is a ramp with negative
acceleration rather than the jump the thesis's simulator made.

Everything here works in one dimension, in the move's own units: metres for straight
and curved motion, wheel metres for rotation in place (A.2.2).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Phase:
    """A stretch of constant acceleration."""

    duration: float
    accel: float


class VelocityProfile:
    """Position and velocity over time for one move, starting at position 0.

    The profile is planned in the positive frame and `direction` (+1 or -1) applied on
    evaluation. `length` is the exact distance to the target, so that a finished move
    reports exactly where it was sent, as the thesis's simulator did.
    """

    def __init__(
        self, direction: int, start_speed: float, phases: tuple[Phase, ...], length: float
    ):
        self.direction = direction
        self.start_speed = start_speed
        self.phases = phases
        self.length = length
        self._starts = [0.0]
        self._positions = [0.0]
        self._speeds = [start_speed]
        for phase in phases:
            u = self._speeds[-1]
            self._positions.append(
                self._positions[-1] + u * phase.duration + phase.accel * phase.duration**2 / 2
            )
            self._speeds.append(u + phase.accel * phase.duration)
            self._starts.append(self._starts[-1] + phase.duration)

    @property
    def duration(self) -> float:
        """Seconds until the move has stopped."""
        return self._starts[-1]

    @property
    def final_position(self) -> float:
        """Signed position at the end of the move."""
        return self.direction * self.length

    def state_at(self, t: float) -> tuple[float, float]:
        """Signed (position, velocity) at time `t` since the move started."""
        if t >= self.duration:
            return self.final_position, 0.0
        t = max(t, 0.0)
        index = bisect.bisect_right(self._starts, t) - 1
        dt = t - self._starts[index]
        u, a = self._speeds[index], self.phases[index].accel
        position = self._positions[index] + u * dt + a * dt * dt / 2
        return self.direction * position, self.direction * (u + a * dt)

    def arc_length_at(self, t: float) -> float:
        """Distance travelled by time `t`, counting a reversal's way back as distance too."""
        total = 0.0
        for index, phase in enumerate(self.phases):
            if t <= self._starts[index]:
                break
            dt = min(t, self._starts[index + 1]) - self._starts[index]
            total += _unsigned_distance(self._speeds[index], phase.accel, dt)
        return total

    @property
    def reversal_arc_length(self) -> float | None:
        """How far the move has gone when its velocity passes through zero, or None."""
        for index, phase in enumerate(self.phases):
            u, a = self._speeds[index], phase.accel
            if u > 0 and a < 0 and self._speeds[index + 1] < 0:
                return self.arc_length_at(self._starts[index] + u / -a)
        return None


def _unsigned_distance(u: float, a: float, dt: float) -> float:
    """Path length covered in `dt` from speed `u` at acceleration `a`, through zero if need be."""
    end = u + a * dt
    if u * end >= 0:
        return abs(u * dt + a * dt * dt / 2)
    t0 = -u / a
    return abs(u * t0 / 2) + abs(end * (dt - t0) / 2)


def plan_move(
    distance: float, start_velocity: float, peak_speed: float, accel: float
) -> VelocityProfile:
    """Plan a move of `distance` (signed) from `start_velocity` (signed).

    `peak_speed` and `accel` are the board's `v` and `a`, positive whatever the
    direction (A.2.1). A zero distance means "stop as soon as possible", keeping the
    current direction (B.2 StartStraight).
    """
    if peak_speed <= 0 or accel <= 0:
        raise ValueError("speed and acceleration must be positive")
    if distance != 0:
        direction = 1 if distance > 0 else -1
    else:
        direction = 1 if start_velocity >= 0 else -1
    s0 = direction * start_velocity
    total = abs(distance)
    v, a = peak_speed, accel
    stopping = s0 * s0 / (2 * a) if s0 > 0 else 0.0

    phases: tuple[Phase, ...]  # two or three, by the case
    if s0 > 0 and stopping >= total:
        # Too fast to stop at the target: brake through zero, then come back (B.2).
        reverse_peak = math.sqrt(a * (stopping - total))
        phases = (Phase((s0 + reverse_peak) / a, -a), Phase(reverse_peak / a, a))
    elif s0 > v:
        # Slowing to a lower peak speed, then cruising and stopping.
        cruise = total - stopping
        phases = (Phase((s0 - v) / a, -a), Phase(cruise / v, 0.0), Phase(v / a, -a))
    else:
        up = (v * v - s0 * s0) / (2 * a)
        down = v * v / (2 * a)
        cruise = total - up - down
        if cruise >= 0:
            phases = (Phase((v - s0) / a, a), Phase(cruise / v, 0.0), Phase(v / a, -a))
        else:
            # Triangle: the ramps meet before the peak speed is reached.
            peak = math.sqrt((s0 * s0 + 2 * a * total) / 2)
            phases = (Phase((peak - s0) / a, a), Phase(peak / a, -a))
    return VelocityProfile(direction, s0, tuple(p for p in phases if p.duration > 0), total)
