"""What the robot service says: answers to requests, and the events beside the loop's.

The same types on both sides of the daemon's socket (design.md, "Dolphie"): the
console in its own process and one attached to the daemon hold a `Robot`, and hear
these from it.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, TypeAlias

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.missions.go_to import GoReport
from giraff_console.missions.navigation import NavigationState
from giraff_console.missions.patrol_report import PatrolReport, StopReport
from giraff_console.protocol import GiraffError, ReplyValue
from giraff_console.robot.loop_events import LoopEvent, MissionChanged
from giraff_console.robot.mission import Outcome
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c


class SendEnd(enum.Enum):
    """How controller commands asked for together (c.SendCommands) went."""

    ANSWERED = "answered"  # every one sent, and answered
    REFUSED = "refused"  # one refused before any was sent (the guard, a mission, a playback)
    BOARD_REFUSED = "board_refused"  # the board refused one, or garbled its answer:
    # those before it were sent and answered, none after it was sent
    NO_LINK = "no_link"  # no link to the board, or it failed: one sent may not have arrived
    BOARD_RESTARTED = "board_restarted"  # the board was found to have restarted: what it
    # took before is lost with its settings, and none after it was sent
    STOPPED = "stopped"  # an operator's stop came between two: none after it was sent
    FAILED = "failed"  # the console failed sending them (a bug, logged): none after was sent


@dataclass(frozen=True)
class Answer:
    """The board's answer to one controller command: its decoded value (None for `OK`
    or a reply in an encoding of its own, such as the charger's), the lines as they
    came, or the error instead."""

    command: str  # as it went on the wire
    value: ReplyValue = None
    lines: tuple[str, ...] = ()
    error: GiraffError | None = None


@dataclass(frozen=True)
class Sent:
    """What became of controller commands asked for together: the answers, in order,
    to those sent, and why the rest were not (`why`: the refusal or the failure)."""

    end: SendEnd
    answers: tuple[Answer, ...] = ()
    why: str = ""


@dataclass(frozen=True)
class Reply:
    """The answer to one request, for whoever asked: done or refused, and what to say."""

    ok: bool
    text: str = ""
    lines: tuple[str, ...] = ()
    # A mission refused before it started: how it ended, as if it had (not_started,
    # unverified, blocked), for the front ends that report it (cli/go.py).
    refused: Outcome | None = None
    # Controller commands asked for with their answers (c.SendCommands): what came of
    # them, for `giraff-console send`.
    sent: Sent | None = None


@dataclass(frozen=True)
class Controls:
    """Who holds the controls, and who else is attached to watch."""

    holder: str | None
    consoles: tuple[str, ...]


@dataclass(frozen=True)
class RouteShown:
    """What the map shows of navigation: the goal, the route, the shut doors, and what
    the range finder has found in the way (the map frame)."""

    goal: str | None
    path: tuple[tuple[float, float], ...]
    closed: tuple[str, ...]
    obstacles: tuple[tuple[float, float], ...]

    @classmethod
    def of(cls, state: NavigationState) -> RouteShown:
        path = tuple(state.planned.path) if state.planned is not None else ()
        return cls(state.goal, path, tuple(sorted(state.closed)), state.obstacles)


@dataclass(frozen=True)
class RoomRenamed:
    """A room of the floor plan has a new name, saved in the plan's file: every front
    end's map and room list follow (planning/room_names.py)."""

    old: str
    new: str


@dataclass(frozen=True)
class MapDrawn:
    """The map being built as the robot is driven (issue 29), for the screens: its cells
    as a PNG (black occupied, white free, grey unknown, as map_server writes them),
    at most MAP_PICTURE_CELLS a side, and where it lies in the map frame."""

    png: bytes
    resolution: float  # metres a pixel of the picture
    origin: tuple[float, float]  # the lower-left pixel's lower-left corner
    revision: int


@dataclass(frozen=True)
class PlanChanged:
    """The robot plans on another floor plan from now on (a map saved): every front end
    draws and names rooms by it."""

    path: Path


@dataclass(frozen=True)
class Situation:
    """The answer to `status`: what runs, who drives, how the last mission ended, and the
    latest snapshot (service/status.py says it)."""

    mission: str | None
    holder: str | None
    consoles: tuple[str, ...]
    last_mission: MissionChanged | None
    recording: bool
    playing: bool
    # The latest snapshot: where the robot is, the mission's progress, the battery.
    telemetry: Telemetry | None = None
    # The camera's frames a second (None: no camera; 0 while nothing wants its frames).
    camera_fps: float | None = None


@dataclass(frozen=True)
class GoReported:
    """A `go` the service started has ended: how it went, as `go --json` prints it, the
    same in the console's process and across the daemon's socket (issue 26)."""

    report: GoReport


@dataclass(frozen=True)
class PatrolStopReported:
    """A stop of a patrol the service runs has ended: arrived, failed and passed over,
    or the patrol ended on its way there. How it went, as `patrol --json` prints its
    line, the same in the console's process and across the daemon's socket (issue 26)."""

    report: StopReport


@dataclass(frozen=True)
class PatrolReported:
    """A patrol the service ran has ended (after its stops' reports): how it went, as
    `patrol --json` prints its last line."""

    report: PatrolReport


ServiceEvent: TypeAlias = (
    LoopEvent | Controls | RouteShown | RoomRenamed | GoReported | PatrolStopReported
    | PatrolReported | SharedFrame | MapDrawn | PlanChanged
)  # fmt: skip
ServiceListener: TypeAlias = Callable[[ServiceEvent], None]
Answered: TypeAlias = Callable[[Reply], None]


class Robot(Protocol):
    """What a front end holds: the robot service in its own process (RobotService), or
    a daemon's across its socket (service/remote.py)."""

    def post(self, request: c.Request, answered: Answered) -> None:
        """Ask, in order; `answered` gets the reply (on another thread, perhaps)."""

    def subscribe(self, listener: ServiceListener, *, vital: bool = False) -> None: ...
    def unsubscribe(self, listener: ServiceListener) -> None: ...
    def close(self) -> None: ...
