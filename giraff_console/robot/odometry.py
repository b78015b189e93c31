"""Dead reckoning from successive motor states (§2.3.1, §3.2.1.5).

The distance comes from the wheel odometers `imdl` and `imdr`, which never restart. The
move counters `cdis` and `cang` restart with every relative move, and teleop preempts
several times a second, so differencing them would lose the distance covered between
the last poll and each preemption.

The heading changes by the curvature of the board's own gear ratio, vg / 0.2495 1/m
(A.2.3), while the robot moves along a curve, and by the wheels' difference while it
rotates in place. The position is integrated at the midpoint heading of each step,
which is exact to second order where the thesis's estimate was first order; along a
clothoid the mean of the two gear ratio samples is exact, since the ratio ramps
linearly with distance.

The casters' effect (§3.2.1.5) is invisible here, as it is to the board.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.errors import ProtocolError
from giraff_console.protocol.kinematics import WHEEL_BASE_M, curvature

# Faster than a Giraff wheel ever turns, and a margin for the first sample's timing.
MAX_WHEEL_SPEED = 2.0
JUMP_MARGIN_M = 0.05


@dataclass(frozen=True)
class Pose:
    """A planar pose: metres, and radians counter-clockwise from +x."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0

    @property
    def heading_deg(self) -> float:
        """The heading in degrees, between 0 and 360 as the thesis displayed it (B.2)."""
        return math.degrees(self.heading) % 360.0


class Odometry:
    """Integrates the robot's pose from one motor state to the next."""

    def __init__(self, pose: Pose | None = None) -> None:
        self.pose = pose or Pose()
        self._last: MotorState | None = None

    def reset(self, pose: Pose | None = None, reference: MotorState | None = None) -> None:
        """Start again from `pose`; the next step is taken from `reference`, or, without
        one, the next state is taken as the new reference."""
        self.pose = pose or Pose()
        self._last = reference

    @property
    def reference(self) -> MotorState | None:
        """The state the next step will be taken from."""
        return self._last

    def update(self, state: MotorState) -> Pose:
        """Advance the pose by what the wheels did since the previous state."""
        if state.imdl is None or state.imdr is None:
            raise ProtocolError("this board does not report wheel distances (imdl, imdr)")
        last, self._last = self._last, state
        if last is None or last.imdl is None or last.imdr is None:
            return self.pose
        left = state.imdl - last.imdl
        right = state.imdr - last.imdr
        elapsed = max(0.0, state.received_at - last.received_at)
        if max(abs(left), abs(right)) > MAX_WHEEL_SPEED * elapsed + JUMP_MARGIN_M:
            # Further than any wheel can go: the board restarted its odometers, as after
            # a power cycle. Keep the pose; this sample is the new reference.
            return self.pose
        distance = (left + right) / 2
        mean_gear = (state.cvg + last.cvg) / 2
        if mean_gear != 0.0 and left * right > 0:
            # Curved motion: positive gear ratios turn right, clockwise.
            turn = -curvature(mean_gear) * distance
        else:
            # Straight (no difference) or rotating in place (wheels in opposite senses).
            turn = (right - left) / WHEEL_BASE_M
        mid = self.pose.heading + turn / 2
        self.pose = Pose(
            self.pose.x + distance * math.cos(mid),
            self.pose.y + distance * math.sin(mid),
            self.pose.heading + turn,
        )
        return self.pose
