"""The safety limits that every typed controller command must respect (design.md).

Speed, acceleration and gear ratio limits hold for typed commands as for teleop, and a
typed `set p` may not put the robot further ahead than a dead console may let it run.

The board brakes at the acceleration `a` of its last move, so `a` bounds a runaway too:
from a speed u the robot needs u^2 / 2a to stop. A typed command is checked without
knowing how fast the robot goes, so `a` must stop it from the top speed within the
runaway limit. A mission's commands are checked on the control loop's thread right
after a poll, knowing the speed the robot may have when the move starts; its moves may
use any acceleration that still stops the robot within the limit from that speed,
which is what lets a jerk-limited profile ease into and out of its ramps.
"""

from __future__ import annotations

from collections.abc import Mapping

from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import CommandError
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.teleop import DriveLimits


def check_command(command: Command, limits: DriveLimits, board: Mapping[str, str],
                  speed: float | None = None) -> None:  # fmt: skip
    """Raise CommandError, saying why, for a command outside the limits.

    `board` is what the board holds for its next move, as sent on the wire. A move
    (`set p`, `set undock`) is only allowed when everything it will use is known and
    within the limits; in rotation (r <= 0) `p` is in degrees (A.2.2). `speed`, when
    known, bounds how fast the robot (its wheels, when rotating) may go as the move
    starts, in m/s.
    """
    if command.kind != "set":
        return
    name, value = command.name, float(command.value)  # type: ignore[arg-type]
    _check_setting(name, value, limits, speed)
    if name in ("p", "undock"):
        for needed in ("r", "mode", "v", "a", "vg"):
            if needed not in board:
                raise CommandError(f"the board's {needed} is unknown; set it first")
            _check_setting(needed, float(board[needed]), limits, speed)
    if name == "p":
        rotating = float(board["r"]) <= 0
        reach = abs(value) / TURN_FACTOR_DEG_PER_M if rotating else abs(value)
        if reach > limits.runaway:
            unit = (
                f"{limits.runaway * TURN_FACTOR_DEG_PER_M:.0f} degrees"
                if rotating
                else f"{limits.runaway} m"
            )
            raise CommandError(f"p beyond {unit}; a dead console would let the robot run that far")


def braking_accel(speed: float, runaway: float) -> float:
    """The gentlest acceleration that stops the robot from `speed` within `runaway`."""
    return speed * speed / (2 * runaway)


def _check_setting(name: str, value: float, limits: DriveLimits, speed: float | None) -> None:
    if name == "v" and not 0 < value <= limits.max_speed:
        raise CommandError(f"v must be in (0, {limits.max_speed}] m/s")
    if name == "a":
        low = limits.min_accel if speed is None else braking_accel(speed, limits.runaway)
        if value <= 0 or not low <= value <= limits.accel:
            raise CommandError(f"a must be in [{low:.3f}, {limits.accel}] m/s^2")
    if name == "vg" and abs(value) >= 0.51:
        raise CommandError("|vg| must stay below 0.51 (§3.2.1.4)")
    if name == "mode" and value != 0:
        # Absolute targets can lie anywhere, and buffered moves add up: either would let
        # a typed target reach further than the runaway limit.
        raise CommandError("typed commands drive in relative, unbuffered mode 0")
    if name == "undock" and not 0 < abs(value) <= limits.runaway:
        raise CommandError(f"undock must back out at most {limits.runaway} m")
