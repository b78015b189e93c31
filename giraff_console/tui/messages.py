"""Messages from the control loop's thread to the UI."""

from __future__ import annotations

from dataclasses import dataclass

from textual.message import Message

from giraff_console.link import Exchange
from giraff_console.robot.control_loop import Telemetry


@dataclass
class TelemetryUpdated(Message):
    """A new snapshot; a queue of them collapses into the newest (design.md)."""

    telemetry: Telemetry

    def __post_init__(self) -> None:
        super().__init__()

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, TelemetryUpdated)


@dataclass
class ExchangeSeen(Message):
    """A command and its reply, for the transcript."""

    exchange: Exchange

    def __post_init__(self) -> None:
        super().__init__()


@dataclass
class StatusNote(Message):
    """A line for the status log."""

    text: str

    def __post_init__(self) -> None:
        super().__init__()
