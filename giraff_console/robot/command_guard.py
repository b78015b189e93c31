"""The safety limits that every typed controller command must respect (design.md).

Speed, acceleration and gear ratio limits hold for typed commands as for teleop, and a
typed `set p` may not put the robot further ahead than a dead console may let it run.
"""

from __future__ import annotations

from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import CommandError
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.teleop import DriveLimits


def check_command(command: Command, limits: DriveLimits, rotating: bool) -> None:
    """Raise CommandError, with the reason, for a command outside the limits.

    `rotating` says whether the board's style is rotation in place (r = 0), where `p`
    is in degrees (A.2.2).
    """
    if command.kind != "set":
        return
    name, value = command.name, float(command.value)  # type: ignore[arg-type]
    if name == "v" and not 0 < value <= limits.max_speed:
        raise CommandError(f"refused: v must be in (0, {limits.max_speed}] m/s")
    if name == "a" and not 0 < value <= limits.accel:
        raise CommandError(f"refused: a must be in (0, {limits.accel}] m/s^2")
    if name == "vg" and abs(value) >= 0.51:
        raise CommandError("refused: |vg| must stay below 0.51 (§3.2.1.4)")
    if name == "mode" and value != 0:
        # Absolute targets can lie anywhere, and buffered moves add up: either would let
        # a typed target reach further than the runaway limit.
        raise CommandError("refused: typed commands drive in relative, unbuffered mode 0")
    if name == "p":
        reach = abs(value) / TURN_FACTOR_DEG_PER_M if rotating else abs(value)
        if reach > limits.runaway:
            unit = f"{limits.runaway * TURN_FACTOR_DEG_PER_M:.0f} degrees" if rotating else (
                f"{limits.runaway} m"
            )  # fmt: skip
            raise CommandError(
                f"refused: p beyond {unit}; a dead console would let the robot run that far"
            )
    if name == "undock" and abs(value) > limits.runaway:
        raise CommandError(f"refused: undock further than {limits.runaway} m")
