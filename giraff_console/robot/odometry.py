"""Dead reckoning from successive motor states (§2.3.1, §3.2.1.5).

The distance comes from the wheels, read one of three ways (wheel_odometers.py): the
thesis's `imdl`/`imdr` totals, later boards' increments, or the encoders. Never from the
move counters `cdis` and `cang`: they restart with every relative move, and teleop
preempts several times a second, so differencing them would lose the distance covered
between the last poll and each preemption.

The heading changes by the wheels' difference over the wheel base, whatever the robot
does: (right - left) / wheel_base is the exact change of a differential drive's heading
for any path between two samples, a curve, a rotation on the spot or both in one step.
The board's own gear ratio (`cvg`) would give the curvature only on the thesis's board
and only in gear-ratio mode: later boards' mode bit 2 makes `vg` an angular velocity
(wire-facts), and a robot whose wheels are not 0.499 m apart (one driver uses 0.467 m)
curves by its real wheel base, not by the 0.2495 m the board's formula assumes. So the
wheel base is a setting (`[board] wheel_base`). The position is integrated at the
midpoint heading of each step, which is exact to second order where the thesis's
estimate was first order.

The casters' effect (§3.2.1.5) is invisible here, as it is to the board.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.errors import ProtocolError
from giraff_console.protocol.kinematics import WHEEL_BASE_M
from giraff_console.robot.wheel_odometers import Reading, WheelOdometers, odometers_for


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

    def __init__(self, pose: Pose | None = None, *, wheel_base: float = WHEEL_BASE_M,
                 reading: Reading | str = Reading.TOTALS) -> None:  # fmt: skip
        if not wheel_base > 0:
            raise ValueError("the wheel base must be positive")
        self.pose = pose or Pose()
        self.wheel_base = wheel_base
        self.odometers: WheelOdometers = odometers_for(reading)
        # Metres the robot's centre has travelled, either way, since it was made: what
        # the first-motion check compares with cdis.
        self.distance = 0.0
        # Metres each wheel has turned since it was made, as the board's totals would
        # count them, whichever way they are read (OdometryFeed.as_totals).
        self.wheels = (0.0, 0.0)
        self._last: MotorState | None = None
        # When the last state was fed, whatever became of the reference since: a reading
        # whose reads consume what it counts needs it to judge the first sample after.
        self._fed_at: float | None = None

    @property
    def reading(self) -> Reading:
        return self.odometers.reading

    def reset(self, pose: Pose | None = None, reference: MotorState | None = None) -> None:
        """Start again from `pose`; the next step is taken from `reference`, or, without
        one, the next state is the new reference (see `update` for increments)."""
        self.pose = pose or Pose()
        self._last = reference
        if reference is not None:
            self._fed_at = reference.received_at

    def use(self, reading: Reading | str) -> None:
        """Read the wheels another way from now on; the pose stays, and the next state is
        the new reference (one reading's reference means nothing to another)."""
        self.odometers = odometers_for(reading)
        self._last = None

    def take_over(self, other: Odometry) -> None:
        """Carry on as `other` does: its reading, its pose, its reference."""
        self.odometers = other.odometers
        self.wheel_base = other.wheel_base
        self.pose = other.pose
        self._last = other.reference
        self._fed_at = other._fed_at

    @property
    def reference(self) -> MotorState | None:
        """The state the next step will be taken from."""
        return self._last

    def wants(self, state: MotorState, automatic: bool) -> bool:
        """Whether `state` is to be integrated: the console's own polls always are (when
        they carry this reading's values); any other read of bulk_data only when it
        resets what this reading counts."""
        return self.odometers.usable(state) and (automatic or self.odometers.consumed_by_reads)

    def update(self, state: MotorState) -> Pose:
        """Advance the pose by what the wheels did since the previous state."""
        if not self.odometers.usable(state):
            raise ProtocolError(f"this board does not report {self.odometers.needs}")
        last, self._last = self._last, state
        fed_at, self._fed_at = self._fed_at, state.received_at
        if last is not None and self.odometers.usable(last):
            travel = self.odometers.travel(last, state)
        elif fed_at is not None and state.received_at >= fed_at:
            # No reference (a new reading, a reset): totals and counts only become one,
            # but increments are what the wheels did since the previous read, which is
            # gone: they count, if the wheels could go that far since the last state fed.
            # (A state older than that is a playback seeking back: a reference only.)
            travel = self.odometers.travel_alone(state, state.received_at - fed_at)
        else:
            return self.pose  # the first state: a reference
        if travel is None:
            # Further than any wheel can go: the board restarted its odometers, as after
            # a power cycle, or garbage. Keep the pose; this sample is the new reference.
            return self.pose
        left, right = travel
        self.wheels = (self.wheels[0] + left, self.wheels[1] + right)
        distance = (left + right) / 2
        turn = (right - left) / self.wheel_base
        mid = self.pose.heading + turn / 2
        self.pose = Pose(
            self.pose.x + distance * math.cos(mid),
            self.pose.y + distance * math.sin(mid),
            self.pose.heading + turn,
        )
        self.distance += abs(distance)
        return self.pose
