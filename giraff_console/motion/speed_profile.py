"""How fast to go where along a path: jerk-limited speed profiles (§2.7, A.1, A.2).

"The Giraff's motors have ramp-up and ramp-down times that may need to be taken into
account" (§2.7): the board ramps its speed at a constant acceleration `a` to a cap `v`
(A.1, Figure A.1), and in curved motion its gear ratio at `vgr` per metre (A.2.3). A
step in acceleration is a jolt, and the thesis warns that sudden changes stress the
hardware (A.1, §3.2.1.4); the console therefore plans every motion with a jerk limit as
well, and commands the board along the plan tick by tick.

A `Drive` is cut into pieces, at every segment boundary and every slow zone's ends, and
each piece gets a speed cap:

- the outer wheel of a curve turns at v * (1 + |vg|) (the corrected formulas, A.2.3), so
  the centre speed is lowered until no wheel exceeds `v_max`;
- v^2 * |k| is the sideways acceleration in a turn; a tall robot sways if it is large;
- a doorway (`SlowZone`) has its own cap.

Speeds at the piece boundaries come from a forward and a backward pass (what can be
reached from the start, what can still stop at the end), and ruckig computes the
time-optimal jerk-limited motion of each piece between them. A `Rotation` is one piece,
measured in wheel metres because that is how the board takes turns (A.2.2, §3.2.1.3).
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, fields
from itertools import pairwise

import ruckig

from giraff_console.motion.path import Drive, Rotation, gear_of
from giraff_console.protocol.kinematics import TURN_RADIUS_M

# Boundaries closer than this (metres) are one boundary, and a shorter drive is no drive:
# ruckig takes a distance below about 1e-17 m as already covered, so a sliver of a piece
# would come back as a jump.
_MERGE_M = 1e-9
# Halvings of the speed interval when looking for the highest reachable speed; 2^-50 of
# the speed range is far finer than the board's resolution.
_BISECTIONS = 50


@dataclass(frozen=True)
class MotionLimits:
    """How hard the robot may be driven: speeds in m/s (wheel or centre), a_max, j_max."""

    v_max: float = 0.4  # centre speed, and the speed no wheel may exceed in a curve
    a_max: float = 0.5  # the thesis's DEF_ACCEL (B.2)
    j_max: float = 1.0
    lateral_accel: float = 0.3  # v^2 * |k| in turns
    door_speed: float = 0.3  # through doorways
    rotation_speed: float = 0.4  # wheel speed when turning on the spot

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{field.name} must be positive and finite, not {value}")
        if self.rotation_speed > self.v_max:
            raise ValueError(
                f"rotation_speed {self.rotation_speed} exceeds v_max {self.v_max}: "
                "the wheels would outrun their own limit"
            )
        if self.door_speed > self.v_max:
            raise ValueError(f"door_speed {self.door_speed} exceeds v_max {self.v_max}")


@dataclass(frozen=True)
class SlowZone:
    """A stretch of a drive (metres from its start) with a lower speed cap: a doorway."""

    start: float
    end: float
    speed: float

    def __post_init__(self) -> None:
        if not self.end > self.start:
            raise ValueError(f"a slow zone must end after it starts ({self.start}..{self.end})")
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"a slow zone's speed must be positive, not {self.speed}")


def ramp_distance(v0: float, v1: float, limits: MotionLimits) -> float:
    """The shortest distance over which the speed can go from v0 to v1, jerk-limited and
    with zero acceleration at both ends.

    The ramp takes T = 2 sqrt(|dv| / j) if it never reaches a_max (|dv| <= a^2 / j), else
    |dv| / a + a / j; its speed is point-symmetric about the middle, so the mean speed is
    (v0 + v1) / 2.
    """
    a, j = limits.a_max, limits.j_max
    dv = abs(v1 - v0)
    duration = 2.0 * math.sqrt(dv / j) if dv <= a * a / j else dv / a + a / j
    return (v0 + v1) / 2.0 * duration


def _reachable_speed(v_from: float, distance: float, cap: float, limits: MotionLimits) -> float:
    """The highest speed, at most `cap`, that a ramp from `v_from` reaches within `distance`.

    The bisection keeps the lower end, so the answer never asks ruckig for a ramp shorter
    than it can drive (it then fails rather than overshoot, as reversing is not allowed).
    """
    if ramp_distance(v_from, cap, limits) <= distance:
        return cap
    low, high = v_from, cap
    for _ in range(_BISECTIONS):
        middle = (low + high) / 2.0
        if ramp_distance(v_from, middle, limits) <= distance:
            low = middle
        else:
            high = middle
    return low


def _boundary_speeds(
    bounds: Sequence[float], caps: Sequence[float], limits: MotionLimits
) -> list[float]:
    """Speeds at the piece boundaries: at rest at both ends, else the lower adjacent cap,
    lowered to what can be reached from the start and what can still stop at the end."""
    pieces = len(caps)
    speeds = [0.0, *(min(caps[i - 1], caps[i]) for i in range(1, pieces)), 0.0]
    for i in range(pieces):
        length = bounds[i + 1] - bounds[i]
        speeds[i + 1] = min(speeds[i + 1], _reachable_speed(speeds[i], length, caps[i], limits))
    # A ramp up and the same ramp down take the same distance, so braking is the mirror.
    for i in reversed(range(pieces)):
        length = bounds[i + 1] - bounds[i]
        speeds[i] = min(speeds[i], _reachable_speed(speeds[i + 1], length, caps[i], limits))
    return speeds


class Profile:
    """Position `s`, speed and acceleration over time along one drive (metres of path) or
    one rotation (wheel metres), from rest to rest. Built by `drive_profile` and
    `rotation_profile`; the executor samples it every control tick."""

    def __init__(
        self, bounds: Sequence[float], caps: Sequence[float], pieces: Sequence[ruckig.Trajectory]
    ) -> None:
        self._bounds = tuple(bounds)  # one more than pieces: s at each piece boundary
        self._caps = tuple(caps)
        self._pieces = tuple(pieces)  # each starts at s = 0 and t = 0: its own frame
        starts = [0.0]
        for piece in self._pieces:
            starts.append(starts[-1] + piece.duration)
        self._starts = tuple(starts)
        self.duration: float = starts[-1]
        self.length: float = self._bounds[-1]

    def at(self, t: float) -> tuple[float, float, float]:
        """(s, v, a) at `t` seconds since the start; before it at rest at 0, after it at
        rest at `length`."""
        if not self._pieces:
            return 0.0, 0.0, 0.0
        t = min(max(t, 0.0), self.duration)
        i = min(bisect_right(self._starts, t) - 1, len(self._pieces) - 1)
        position, velocity, acceleration = self._pieces[i].at_time(t - self._starts[i])
        # Clamped to the piece, so float noise at a boundary cannot make s step back.
        s = min(max(self._bounds[i] + position[0], self._bounds[i]), self._bounds[i + 1])
        return s, velocity[0], acceleration[0]

    def time_at(self, s: float) -> float:
        """The first time the profile reaches `s`."""
        if s <= 0.0 or not self._pieces:
            return 0.0
        if s >= self.length:
            return self.duration
        i = bisect_left(self._bounds, s) - 1  # the piece that ends at or beyond s
        piece = self._pieces[i]
        into = piece.get_first_time_at_position(0, s - self._bounds[i])
        # None only when the piece's end falls short of s by float noise: s is its end.
        return self._starts[i] + (piece.duration if into is None else into)

    def speed_cap_at(self, s: float) -> float:
        """The speed cap in force at `s`; on a boundary, the lower of the two pieces' (0 when
        there is nothing to drive)."""
        if not self._caps:
            return 0.0
        i = min(max(bisect_right(self._bounds, s) - 1, 0), len(self._caps) - 1)
        if i > 0 and s == self._bounds[i]:
            return min(self._caps[i - 1], self._caps[i])
        return self._caps[i]


def _plan(bounds: Sequence[float], caps: Sequence[float], limits: MotionLimits) -> Profile:
    """Ruckig's time-optimal motion for each piece between its boundary speeds.

    Each piece is planned in its own frame (from s = 0), so a piece a micrometre long
    late in a long drive does not lose its precision to the large s it starts at.
    """
    speeds = _boundary_speeds(bounds, caps, limits)
    generator = ruckig.Ruckig(1)  # no control cycle: offline calculation only
    request = ruckig.InputParameter(1)
    request.current_acceleration = [0.0]
    request.target_acceleration = [0.0]
    request.max_acceleration = [limits.a_max]
    request.max_jerk = [limits.j_max]
    # A path has a direction: without this, a time-optimal plan may back up briefly.
    request.min_velocity = [0.0]
    pieces = []
    for i, cap in enumerate(caps):
        request.current_position = [0.0]
        request.current_velocity = [speeds[i]]
        request.target_position = [bounds[i + 1] - bounds[i]]
        request.target_velocity = [speeds[i + 1]]
        request.max_velocity = [cap]
        piece = ruckig.Trajectory(1)
        # The Python binding raises on every failure (bad input, no profile found); the
        # Result it returns otherwise is always Working.
        try:
            generator.calculate(request, piece)
        except ruckig.RuckigError as error:
            raise ValueError(
                f"ruckig could not plan {bounds[i]:.6g}..{bounds[i + 1]:.6g} m from "
                f"{speeds[i]:.6g} to {speeds[i + 1]:.6g} m/s under {cap:.6g} m/s: "
                f"{str(error).strip()}"
            ) from error
        pieces.append(piece)
    return Profile(bounds, caps, pieces)


def _curve_cap(curvature: float, limits: MotionLimits) -> float:
    """The highest centre speed at which no wheel exceeds v_max and the sideways
    acceleration stays within its limit."""
    k = abs(curvature)
    cap = limits.v_max / (1.0 + abs(gear_of(k)))  # already at most v_max itself
    return min(cap, math.sqrt(limits.lateral_accel / k)) if k > 0.0 else cap


def drive_profile(drive: Drive, limits: MotionLimits, zones: Sequence[SlowZone] = ()) -> Profile:
    """The jerk-limited profile of a drive, from rest at its start to rest at its end,
    slowed through `zones`. A drive shorter than a nanometre has nothing to drive."""
    segment_starts = [0.0]
    for segment in drive.segments:
        segment_starts.append(segment_starts[-1] + segment.length)
    length = segment_starts[-1]
    if length <= _MERGE_M:
        return Profile((0.0,), (), ())
    ends = sorted((*segment_starts[1:-1], *(z.start for z in zones), *(z.end for z in zones)))
    bounds = [0.0]
    for s in ends:
        if bounds[-1] + _MERGE_M < s < length - _MERGE_M:
            bounds.append(s)
    bounds.append(length)
    caps = []
    for a, b in pairwise(bounds):
        # A merged boundary lets a piece reach a hair into the next segment or zone; every
        # overlap counts, which errs on the slow side. k is linear along a segment, so its
        # largest |k| over an overlap is at one of the overlap's ends.
        k = 0.0
        j = bisect_right(segment_starts, a) - 1
        while j < len(drive.segments) and segment_starts[j] < b:
            segment, start = drive.segments[j], segment_starts[j]
            k = max(k, abs(segment.curvature_at(a - start)), abs(segment.curvature_at(b - start)))
            j += 1
        cap = _curve_cap(k, limits)
        for zone in zones:
            if zone.start < b and a < zone.end:
                cap = min(cap, zone.speed)
        caps.append(cap)
    return _plan(bounds, caps, limits)


def rotation_profile(rotation: Rotation, limits: MotionLimits) -> Profile:
    """The jerk-limited profile of a turn on the spot, in wheel metres: |angle| times the
    turn radius (§3.2.1.3). Always forward; the caller gives the wheels their sign."""
    length = abs(rotation.angle) * TURN_RADIUS_M
    if length <= _MERGE_M:
        return Profile((0.0,), (), ())
    return _plan((0.0, length), (limits.rotation_speed,), limits)


def move_profile(distance: float, cap: float, limits: MotionLimits) -> Profile:
    """The jerk-limited profile of a move of `distance` metres from rest to rest, at
    most `cap` m/s."""
    if distance <= _MERGE_M:
        return Profile((0.0,), (), ())
    return _plan((0.0, distance), (min(cap, limits.v_max),), limits)
