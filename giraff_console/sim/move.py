"""One move of the board: its parameters, its style, and the true pose it moves.

The plain types the wheel controller (sim/drive.py) works with, kept apart from it.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.sim.gear import GearEnvelope
from giraff_console.sim.profile import VelocityProfile


class Style(enum.Enum):
    """Movement style chosen with `set r` (A.4.2)."""

    ROTATE = "rotate"
    PATH = "path"
    # With r < 0 the thesis saw rotations reported as wheel distances (B.2 StartRotate).
    ROTATE_AS_DISTANCE = "rotate-as-distance"

    @classmethod
    def of(cls, r: float) -> Style:
        if r == 0:
            return cls.ROTATE
        return cls.PATH if r > 0 else cls.ROTATE_AS_DISTANCE


@dataclass
class MoveParams:
    """The parameters of one move; the defaults are the thesis simulator's (B.2)."""

    v: float = 0.6
    a: float = 0.6
    r: float = 0.0
    p: float = 0.0
    vg: float = 1.0
    vgr: float = 0.4
    cdp: float = 0.0
    mode: int = 0


@dataclass(frozen=True)
class TruePose:
    """Where the robot really is: metres, and radians counter-clockwise from +x."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0


@dataclass
class RunningMove:
    """The move the wheels are on: its plan, and how far along it they are."""

    params: MoveParams
    style: Style
    started: float
    profile: VelocityProfile
    gear: GearEnvelope
    origin: float
    position: float = 0.0
    gear_ratio: float = 0.0
    # Mode 2 (later firmware): the constant gear ratio that turns at `vg` degrees per
    # second at the cruise speed, forwards; None for every other move.
    angular_gear: float | None = None


class MoveRefused(ValueError):
    """A move the board cannot plan, such as one with zero speed."""


def mode2_gear(params: MoveParams) -> float:
    """Mode 2's gear ratio: turning at `vg` degrees per second at the peak speed `v`.

    The curvature is radians(vg) / v, and the board's gear ratio for it kappa * 0.2495
    (wire-facts "Quirks"). A positive vg turns counter-clockwise (to the left), so the
    gear ratio, positive to the right, is its negative: the deployed drivers send ROS's
    angular velocity, positive to the left, as `vg` unchanged, and their robots turn left
    (wire-facts "What the deployed drivers do", Sign in `mode 2`).
    """
    return -math.radians(params.vg) / abs(params.v) * TURN_RADIUS_M


def mode2_turns_on_the_spot(params: MoveParams) -> bool:
    """A mode 2 move with v = 0 and a non-zero vg turns on the spot at vg degrees per
    second (wire-facts "What the deployed drivers do": the drivers turn this way, and
    the board does). It needs a direction (p != 0) and an acceleration (a != 0):
    otherwise it is a stop, like every `set p` with a zero v or a on later boards."""
    return params.v == 0 and params.vg != 0 and params.a != 0 and params.p != 0


def mode2_spin(params: MoveParams) -> tuple[float, float]:
    """Mode 2's turn on the spot: each wheel's travel (metres, positive clockwise, as
    the board's rotations count) and its peak speed (m/s), by the board's 0.499 m.

    How far one `set p` turns is not documented (assumption): |p| metres of each wheel's
    travel, as every other move counts p in wheel metres (229.6 degrees for p = 1), so a
    driver that dies mid-turn leaves a bounded turn, as `p = +-1` bounds its straight
    runs. The turn's direction is vg's alone (counter-clockwise when positive), whatever
    p's sign: the drivers send p = +-1 from the sign of their forward speed, which is 0.
    """
    return -math.copysign(abs(params.p), params.vg), math.radians(abs(params.vg)) * TURN_RADIUS_M
