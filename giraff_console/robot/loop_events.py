"""What the control loop says, as one stream of events (issue 15).

Everything that comes back from the loop is one of four things: a `Telemetry`
snapshot after each tick, an `Exchange` with the board (live, or recorded and played
back), a `Note` for the operator, or a `MissionChanged` as a mission starts or ends.
A `Listener` subscribed to the loop gets every one of them (on the loop's thread, but a
note on the thread that made it) and keeps those it wants, by type; one stream, rather
than a callback per kind, is what the daemon carries to other processes unchanged
(service/daemon.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeAlias

from giraff_console.link import Exchange, Observer
from giraff_console.robot.mission import MissionEnd
from giraff_console.robot.telemetry import Telemetry


@dataclass(frozen=True)
class Note:
    """A line for the operator: what the loop did or could not do, and why."""

    text: str


@dataclass(frozen=True)
class MissionChanged:
    """A mission started (`end` None) or ended, and how (robot/mission.py, MissionEnd).
    The daemon keeps the last one, so that a console attached later can say how the
    night's patrol went."""

    name: str
    running: bool
    end: MissionEnd | None = None


LoopEvent: TypeAlias = Telemetry | Exchange | Note | MissionChanged
Listener: TypeAlias = Callable[[LoopEvent], None]


@dataclass(frozen=True)
class ExchangeTap:
    """A listener that hands the exchanges alone on to a link observer (a recording, a
    route being taught). Two taps of the same observer are equal, so the tap made to
    unsubscribe matches the one subscribed, and nobody has to keep it."""

    observer: Observer

    def __call__(self, event: LoopEvent) -> None:
        if isinstance(event, Exchange):
            self.observer(event)
