"""The virtual gear ratio of a curved move, as a function of distance travelled (A.2.3).

The gear ratio ramps from its value at the start of the move towards `vg` at `vgr` per
metre, holds, and from the clothoid deceleration point `cdp` ramps back towards zero at
the same rate. A ramp that is linear in distance makes the path a clothoid, since the
curvature is vg / 0.2495 1/m. The board resets the ratio to zero when the move stops.

Signs follow B.2 StartStraight: the turn direction comes from the sign of `vgr`, and the
ratio flips with the direction of travel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class GearEnvelope:
    """Gear ratio along a move. `start` and `peak` are in the envelope's positive frame."""

    sign: int = 1
    start: float = 0.0
    peak: float = 0.0
    rate: float = 0.0
    ramp_down_at: float = 0.0
    # Arc length at which the ratio is forced to zero: a reversal brakes to a stop there.
    zero_after: float = math.inf

    def at(self, arc_length: float) -> float:
        """The signed gear ratio after `arc_length` metres of the move."""
        if arc_length >= self.zero_after:
            return 0.0
        if arc_length < self.ramp_down_at:
            return self.sign * _towards(self.start, self.peak, self.rate * arc_length)
        top = _towards(self.start, self.peak, self.rate * self.ramp_down_at)
        return self.sign * _towards(top, 0.0, self.rate * (arc_length - self.ramp_down_at))


NO_GEAR = GearEnvelope()


def _towards(value: float, target: float, step: float) -> float:
    """`value` moved towards `target` by at most `step`."""
    if value < target:
        return min(value + step, target)
    return max(value - step, target)


def plan_gear(
    *,
    direction: int,
    start_vg: float,
    vg: float,
    vgr: float,
    cdp: float,
    length: float,
    curved: bool,
    reversal_at: float | None,
) -> GearEnvelope:
    """The envelope for a move of `length` metres in `direction`.

    `cdp` is measured from the start of the move; `curved` says whether the style and
    parameters ask for curved motion (r > 50, cdp and vg non-zero); a move that starts
    with a non-zero ratio ramps it down even when it is not itself curved (B.2).
    """
    if not curved and start_vg == 0.0:
        return NO_GEAR
    if vgr == 0.0:
        # Setting vgr to zero makes the real board's ratio jump straight to zero (A.2.3,
        # §3.2.1.4); the thesis's console used exactly this to leave a curve, jerk and all.
        return NO_GEAR
    vg_sign = 1 if vgr > 0 else -1
    frame = vg_sign * direction
    start = frame * start_vg
    ramp_down_at = min(direction * cdp, length) if curved else 0.0
    if reversal_at is not None or ramp_down_at <= 0 or vg == 0.0:
        # No ramp-up: start ramping down at once (B.2, including the reversal case).
        return GearEnvelope(frame, start, start, abs(vgr), 0.0, reversal_at or math.inf)
    return GearEnvelope(frame, start, vg_sign * vg, abs(vgr), ramp_down_at)
