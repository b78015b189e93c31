"""Stopping the robot whatever state the console is in (design.md, safety rules)."""

from __future__ import annotations

import logging
import math

from giraff_console.link import BoardLink, MotorState
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, brake_distance

log = logging.getLogger(__name__)

# The acceleration the console drives with (B.2 DEF_ACCEL); braking uses the same.
STOP_ACCEL = 0.5
# The thesis's 10 ms "reaction time" margin (§3.2.1.2).
REACTION_S = 0.01
# Assumed when the board's speed reading is unusable (gvr infinite at vg = 1): the
# teleop cap, so that the stop target is never inside the real braking distance.
UNKNOWN_SPEED = 0.4
# No stop target goes further than this, whatever the readings say (design.md).
RUNAWAY_M = 0.3


def path_stop_distance(speed: float | None, accel: float) -> float:
    """Signed target that stops a path move: braking distance plus reaction margin."""
    if speed is None:
        speed = UNKNOWN_SPEED
    target = brake_distance(speed, accel) + speed * REACTION_S
    return max(-RUNAWAY_M, min(RUNAWAY_M, target))


def rotation_stop_angle(wheel_speed: float, accel: float) -> float:
    """Signed `set p` in degrees that stops a rotation whose wheels turn at `wheel_speed`."""
    if not math.isfinite(wheel_speed):
        wheel_speed = math.copysign(UNKNOWN_SPEED, wheel_speed)
    wheel = brake_distance(wheel_speed, accel) + wheel_speed * REACTION_S
    return max(-RUNAWAY_M, min(RUNAWAY_M, wheel)) * TURN_FACTOR_DEG_PER_M


def rotation_wheel_speed(state: MotorState, r: float) -> float:
    """Wheel speed (m/s, positive clockwise) of a rotation in place.

    With r = 0 the board reports degrees per second with the sign flipped (A.2.2); with
    r < 0 it reports the wheels' own speed (B.2 StartRotate).
    """
    return -state.gvr / TURN_FACTOR_DEG_PER_M if r == 0 else state.gvr


def stop_commands(state: MotorState, r: float, accel: float = STOP_ACCEL) -> list[Command]:
    """Commands that bring a moving robot to rest as its ramps allow, without reversing.

    `r` is the board's movement style, which decides what `p` means (A.2). A target
    inside the braking distance would make the board brake through zero and come back
    (B.2), so the target is the braking distance plus the reaction margin. The mode goes
    to relative first, in case a move was absolute or buffered; the acceleration to the
    one the braking distance was worked out for; and the gear ratio of a curve ramps
    down (cdp 0) rather than jumping.
    """
    if not state.moving:
        return []
    setup = [Command("set", "mode", 0), Command("set", "a", accel)]
    if r <= 0:
        angle = rotation_stop_angle(rotation_wheel_speed(state, r), accel)
        return [*setup, Command("set", "p", angle)]
    target = path_stop_distance(state.speed, accel)
    return [*setup, Command("set", "cdp", 0), Command("set", "p", target)]


def stop_robot(link: BoardLink) -> bool:
    """Poll the board and command a stop if it moves; never raises. True if it worked."""
    try:
        state = link.bulk()
        if state.moving:
            style = link.get("r")
            assert isinstance(style, int | float)
            for command in stop_commands(state, float(style)):
                link.send(command)
    except GiraffError as error:
        log.warning("could not command a stop: %s", error)
        return False
    return True
