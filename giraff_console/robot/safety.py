"""Stopping the robot whatever state the console is in (design.md, safety rules)."""

from __future__ import annotations

import logging

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


def path_stop_distance(speed: float | None, accel: float) -> float:
    """Signed target that stops a path move: braking distance plus reaction margin."""
    if speed is None:
        speed = UNKNOWN_SPEED
    return brake_distance(speed, accel) + speed * REACTION_S


def rotation_stop_angle(gvr: float, accel: float) -> float:
    """Signed `set p` in degrees that stops a rotation in place (gvr is -degrees/s, A.2.2)."""
    wheel = -gvr / TURN_FACTOR_DEG_PER_M
    return (brake_distance(wheel, accel) + wheel * REACTION_S) * TURN_FACTOR_DEG_PER_M


def stop_commands(state: MotorState, accel: float = STOP_ACCEL) -> list[Command]:
    """Commands that bring a moving robot to rest as its ramps allow, without reversing.

    A target inside the braking distance would make the board brake through zero and
    come back (B.2), so the target is the braking distance plus the reaction margin.
    The mode goes to relative first, in case a move was in absolute mode, and the gear
    ratio of a curve ramps down (cdp 0) rather than jumping.
    """
    if not state.moving:
        return []
    if state.cang != 0.0:
        return [
            Command("set", "mode", 0),
            Command("set", "p", rotation_stop_angle(state.gvr, accel)),
        ]
    target = path_stop_distance(state.speed, accel)
    return [Command("set", "mode", 0), Command("set", "cdp", 0), Command("set", "p", target)]


def stop_robot(link: BoardLink) -> bool:
    """Poll the board and command a stop if it moves; never raises. True if it worked."""
    try:
        for command in stop_commands(link.bulk()):
            link.send(command)
    except GiraffError as error:
        log.warning("could not command a stop: %s", error)
        return False
    return True
