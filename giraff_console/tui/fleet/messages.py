"""Messages from the fleet master's thread (paho's) to the fleet view."""

from __future__ import annotations

from textual.message import Message


class FleetChanged(Message):
    """Something changed on the broker; the view reads the master's latest snapshot, so
    a queue of these collapses into one (design.md)."""

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, FleetChanged)
