"""One move from rest to rest, streamed to the board in steps no longer than the reach.

The board keeps executing its last `set p` if the console dies (design.md), so a move
longer than the console's reach (robot/safety.py) is never sent whole: while more than
the reach is left, the target is renewed every tick, relative and unbuffered (mode 0),
as the thesis renewed its lookahead targets while a key was held (§3.2.1.2). What is
left is measured on the wheel odometers (imdl, imdr) since the move began, as `cdis`
and `cang` restart with every relative move. Once the rest fits within the reach the
target is the move's end, and the board's own ramp stops the robot there; if it stops
short or long (a real board misses by millimetres, §5.5) the difference is driven again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.codec import Command, Number
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, TURN_RADIUS_M
from giraff_console.robot.safety import REACH_M

# Movement styles (A.4.2): any 0 < r <= 50 drives straight; 0 rotates in place.
STRAIGHT_STYLE, ROTATE_STYLE = 1, 0
# A move is done when the robot has stopped this close to its end (path metres, or
# wheel metres turning: 0.25 degrees); further off, the difference is driven again.
DRIVE_DONE_M = 0.002
TURN_DONE_M = math.radians(0.25) * TURN_RADIUS_M
# Targets go out to a tenth of a millimetre, truncated so that none passes the limit.
DECIMALS = 4


@dataclass
class StreamedMove:
    """A turn in place or a straight drive, from rest to rest."""

    turning: bool
    # How far to go: wheel metres clockwise when turning (A.2.2), metres ahead driving.
    total: float
    base: tuple[float, float]  # the wheel odometers when it began
    speed: float  # m/s of the wheels
    accel: float  # m/s^2
    started: bool = False  # its settings have gone out
    final: bool = False  # the target is the move's end, not a renewed step

    def left(self, state: MotorState) -> float:
        """What is still to go, from the wheel odometers."""
        left = (state.imdl or 0.0) - self.base[0]
        right = (state.imdr or 0.0) - self.base[1]
        # Turning clockwise the left wheel goes forward and the right one back.
        done = (left - right) / 2 if self.turning else (left + right) / 2
        return self.total - done

    def step(self, state: MotorState) -> list[Command] | None:
        """This tick's commands: the reach ahead while more is left, else the move's end;
        None once the robot has stopped at the end."""
        left = self.left(state)
        if abs(left) > REACH_M:
            self.final = False
            return self._target(math.copysign(REACH_M, left))
        if not self.final:
            self.final = True
            return self._target(left)
        if state.moving:
            return []  # the board's own ramp stops it at the end (A.1)
        if abs(left) > (TURN_DONE_M if self.turning else DRIVE_DONE_M):
            return self._target(left)  # stopped short or long: the difference again
        return None

    def _target(self, metres: float) -> list[Command]:
        """`set p` for `metres` (wheel metres clockwise when turning), after the move's
        settings if they have not gone out: `r` first, since a change of style resets
        the board's counters (A.4.8)."""
        commands = []
        if not self.started:
            self.started = True
            settings: dict[str, Number] = {
                "r": ROTATE_STYLE if self.turning else STRAIGHT_STYLE,
                "mode": 0,
                "v": self.speed,
                "a": self.accel,
                "vg": 0,  # straight: no curve (A.2.3)
            }
            commands = [Command("set", name, value) for name, value in settings.items()]
        # Turning, p is in degrees, positive to the right (A.2.2).
        value = metres * TURN_FACTOR_DEG_PER_M if self.turning else metres
        value = math.trunc(value * 10**DECIMALS) / 10**DECIMALS
        return [*commands, Command("set", "p", value)]
