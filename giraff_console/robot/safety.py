"""Stopping the robot whatever state the console is in (design.md, safety rules)."""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping

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
# design.md's rule: a console that dies at any moment lets the robot go at most this far.
RUNAWAY_M = 0.3
# How far ahead of the robot the console ever puts the board's target, the robot's own
# travel in metres (wheel metres when turning on the spot). The 5 cm under the rule are
# the margin a loaded machine needs: with targets 0.28 m ahead, a SIGKILL let the robot
# run 0.305 m (issue 12), from a tick that came late and the board's own overshoot.
# No stop target goes further than this either, whatever the readings say.
REACH_M = 0.25


def path_stop_distance(speed: float | None, accel: float) -> float:
    """Signed target that stops a path move: braking distance plus reaction margin."""
    if speed is None:
        speed = UNKNOWN_SPEED
    target = brake_distance(speed, accel) + speed * REACTION_S
    return max(-REACH_M, min(REACH_M, target))


def rotation_stop_angle(wheel_speed: float, accel: float) -> float:
    """Signed `set p` in degrees that stops a rotation whose wheels turn at `wheel_speed`."""
    if not math.isfinite(wheel_speed):
        wheel_speed = math.copysign(UNKNOWN_SPEED, wheel_speed)
    wheel = brake_distance(wheel_speed, accel) + wheel_speed * REACTION_S
    return max(-REACH_M, min(REACH_M, wheel)) * TURN_FACTOR_DEG_PER_M


def rotation_wheel_speed(state: MotorState, r: float) -> float:
    """Wheel speed (m/s, positive clockwise) of a rotation in place.

    With r = 0 the board reports degrees per second with the sign flipped (A.2.2); with
    r < 0 it reports the wheels' own speed (B.2 StartRotate).
    """
    return -state.gvr / TURN_FACTOR_DEG_PER_M if r == 0 else state.gvr


def stop_commands(state: MotorState, r: float, accel: float = STOP_ACCEL,
                  held: Mapping[str, str] | None = None) -> list[Command]:  # fmt: skip
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
        stop = Command("set", "p", angle)
    else:
        setup.append(Command("set", "cdp", 0))
        stop = Command("set", "p", path_stop_distance(state.speed, accel))
    # A setting the board is known to hold already need not be sent again: every
    # exchange is a few milliseconds more of driving on before the stop (`held`, as on
    # the wire). The mode always goes: in another mode `p` means another thing (A.4.8).
    held = held or {}
    needed = [c for c in setup if c.name == "mode" or held.get(c.name) != c.settings[c.name]]
    return [*needed, stop]


def stop_robot(link: BoardLink, held: Mapping[str, str] | None = None) -> bool:
    """Poll the board and command a stop if it moves; never raises. True if it worked.

    `held` is what the board is known to hold for its next move, as sent on the wire
    (Teleop.board_settings): settings it already has are not sent again, and a path
    style is not read back. A rotation style always is: were the board on a path after
    all, a stop worked out in degrees would be taken as metres (A.2.2).
    """
    try:
        state = link.bulk()
        if state.moving:
            known = (held or {}).get("r")
            path = known is not None and float(known) > 0
            style = float(known) if path and known is not None else link.get("r")
            assert isinstance(style, int | float)
            for command in stop_commands(state, float(style), held=held):
                link.send(command)
    except GiraffError as error:
        log.warning("could not command a stop: %s", error)
        return False
    return True
