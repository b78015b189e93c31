"""Backing out of the dock and turning round, streamed by the console (§3.7 U, A.4.9).

The board's own `set undock D` queues two moves: straight back D metres, then 180
degrees in place (A.4.9). Once queued they run to the end whatever happens to the
console: 0.784 m of wheel travel that a console which dies cannot stop (issue 12). So
the console makes the same two moves itself, each streamed in steps no longer than its
reach (missions/streamed_move.py), like every other move.
"""

from __future__ import annotations

import math

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.streamed_move import StreamedMove
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.protocol.codec import Command
from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.robot.mission import Progress

# The board turns clockwise, `p = 180` (A.4.9, B.2 QueueUndock): half a turn of wheel.
HALF_TURN_M = math.pi * TURN_RADIUS_M


class Undock:
    """A Mission: back out `distance` metres, then turn 180 degrees clockwise."""

    def __init__(self, distance: float, limits: MotionLimits | None = None) -> None:
        if not distance > 0 or not math.isfinite(distance):
            raise ValueError("the undock distance must be a positive number of metres")
        self.name = "undock"
        self.distance = distance
        self.limits = limits or MotionLimits()
        self.problem: str | None = None
        # (turning, total): back out, then half a turn clockwise.
        self._plan = [(False, -distance), (True, HALF_TURN_M)]
        self._move: StreamedMove | None = None
        self._left = distance
        self._paused = False

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self._paused or self.finished or state is None:
            return []
        if state.imdl is None or state.imdr is None:
            self.problem = "the board does not report wheel distances (imdl, imdr)"
            return []
        if self._move is None:
            if state.moving:
                return []  # still braking from a pause
            turning, total = self._plan[0]
            base = (state.imdl, state.imdr)
            # A doorway's speed out of the dock: it is a tight spot (settings, [motion]).
            speed = self.limits.rotation_speed if turning else self.limits.door_speed
            self._move = StreamedMove(turning, total, base, speed, self.limits.a_max)
        self._left = abs(self._move.left(state))
        commands = self._move.step(state)
        if commands is None:
            self._plan.pop(0)
            self._move = None
            return []
        return commands

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        """The loop stops the robot; on resuming, the rest of the move is made."""
        self._paused = True

    def resume(self, now: float) -> None:
        if self._paused:
            self._paused = False
            if self._move is not None:
                # What was left when it stopped, from where it stopped.
                turning, total = self._plan[0]
                sign = math.copysign(1.0, total)
                self._plan[0] = (turning, sign * self._left)
                self._move = None

    @property
    def finished(self) -> bool:
        return not self._plan

    @property
    def progress(self) -> Progress:
        """The metres left backing out; turning round, the degrees left, which are no
        metres of the way."""
        if self.finished:
            return Progress(self.name, "done")
        paused = " (paused)" if self._paused else ""
        turning, total = self._plan[0]
        left = self._left if self._move is not None else abs(total)
        if turning:
            degrees = math.degrees(left / TURN_RADIUS_M)
            return Progress(self.name, f"turning round, {degrees:.0f}° left{paused}")
        return Progress(self.name, f"backing out{paused}", left)
