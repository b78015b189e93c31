"""What the control loop runs when the robot drives itself (design.md, missions/).

A mission is stepped by the control loop, on its thread, once per tick and whenever
the time it asked for comes: it gets the latest motor state and answers with the
commands to send now. The loop checks every command against the same limits as typed
commands (knowing the speed just polled), stops the mission when the operator takes the
keys, on ESTOP, when the link is lost and when the mission reports a problem, and stops
the robot when a mission is stopped or paused.
"""

from __future__ import annotations

from typing import Protocol

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.codec import Command


class Mission(Protocol):
    """Something that drives the robot by itself: a route replay, a patrol."""

    name: str

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        """The commands to send at `now`, in order; `state` is the latest poll."""
        ...

    def next_due(self) -> float | None:
        """When the mission next wants to be stepped, if sooner than the next tick."""
        ...

    def pause(self, now: float) -> None:
        """Hold still from `now`; the loop has stopped the robot."""
        ...

    def resume(self, now: float) -> None:
        """Carry on from where `pause` left off."""
        ...

    @property
    def finished(self) -> bool: ...

    @property
    def problem(self) -> str | None:
        """Why the mission cannot go on (a stall, no way left), if it cannot; the loop
        then stops the robot and ends it."""
        ...

    @property
    def progress(self) -> str:
        """One line for the operator: where the mission is and how long it has left."""
        ...
