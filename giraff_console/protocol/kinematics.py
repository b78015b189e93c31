"""Geometry and unit conversions that the wire protocol relies on.

The board speaks in wheel metres even when it rotates in place (A.2.2), and reports the
speed of one wheel, computed with the manufacturer's formula, in curved motion (A.2.3,
§3.2.1.4). These few formulas are shared by the simulator and the console so that both
sides of the wire agree on them.
"""

from __future__ import annotations

import math

# Distance between the drive wheels, from Giraff Technologies (§3.2.1.3).
WHEEL_BASE_M = 0.499
# The wheel bases the console accepts (`[board] wheel_base`, a session's meta.json): a
# Giraff's wheels are about half a metre apart (0.499 m in the thesis, 0.467 m in one
# driver, wire-facts); outside this range the figure is a typo, or centimetres.
WHEEL_BASE_RANGE_M = (0.2, 1.0)
# The Giraff's base is about 0.6 m across: the disc the planner keeps off walls and a
# contact pivots about.
BODY_RADIUS_M = 0.3
# Radius of the circle the wheels follow when rotating in place.
TURN_RADIUS_M = WHEEL_BASE_M / 2
# Degrees of rotation per metre of wheel travel: the thesis's TURN_FACTOR.
TURN_FACTOR_DEG_PER_M = 180.0 / (TURN_RADIUS_M * math.pi)


def brake_distance(speed: float, accel: float) -> float:
    """Distance needed to stop from `speed` at deceleration `accel`, signed like `speed`.

    The thesis's CalcMoveBrakeDist: v * (|v| / a) / 2.
    """
    if accel <= 0:
        raise ValueError("acceleration must be positive")
    return speed * abs(speed) / (2.0 * accel)


def curvature(gear_ratio: float) -> float:
    """Path curvature (1/m) of a curved move; positive gear ratios turn right (A.2.3)."""
    return gear_ratio / TURN_RADIUS_M


def wheel_speeds(speed: float, gear_ratio: float) -> tuple[float, float]:
    """Left and right wheel speeds (or distances) for an overall one and a gear ratio.

    These are the corrected formulas (A.2.3), acknowledged by Giraff Technologies:
    left = v(1 + vg), right = v(1 - vg).
    """
    return speed * (1.0 + gear_ratio), speed * (1.0 - gear_ratio)


def gvr_from_speed(speed: float, gear_ratio: float) -> float:
    """What the board reports as `gvr` in straight or curved motion.

    The board reports the left wheel's speed with the manufacturer's incorrect formula
    v / (1 - vg) (§3.2.1.4, the thesis's GVR_IS_LEFT). At vg = 1 that divides by zero;
    the board then reports infinity.
    """
    divisor = 1.0 - gear_ratio
    if divisor == 0.0:
        return math.copysign(math.inf, speed) if speed else 0.0
    return speed / divisor


def speed_from_gvr(gvr: float, gear_ratio: float) -> float:
    """Overall speed from a reported `gvr`: the inverse of `gvr_from_speed`."""
    return gvr * (1.0 - gear_ratio)
