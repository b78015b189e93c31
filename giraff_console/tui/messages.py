"""Messages from the robot's threads (the control loop's, the daemon's reader) to the UI."""

from __future__ import annotations

from textual.message import Message

from giraff_console.camera.feed import CameraPicture
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.service import commands as c
from giraff_console.service.daemon import Welcome
from giraff_console.service.events import Controls, Reply, RoomRenamed, RouteShown
from giraff_console.service.vocabulary import Exchange, Telemetry


class TelemetryUpdated(Message):
    """A new snapshot; a queue of them collapses into the newest (design.md)."""

    def __init__(self, telemetry: Telemetry) -> None:
        super().__init__()
        self.telemetry = telemetry

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, TelemetryUpdated)


class ExchangeSeen(Message):
    """A command and its reply, for the transcript."""

    def __init__(self, exchange: Exchange) -> None:
        super().__init__()
        self.exchange = exchange


class StatusNote(Message):
    """A line for the status log."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.text = text


class CameraPictureUpdated(Message):
    """A new camera picture; only the newest one matters."""

    def __init__(self, picture: CameraPicture) -> None:
        super().__init__()
        self.picture = picture

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, CameraPictureUpdated)


class NavigationChanged(Message):
    """The route shown on the map, or the doors, changed."""

    def __init__(self, route: RouteShown) -> None:
        super().__init__()
        self.route = route


class RoomNamed(Message):
    """A room of the floor plan was renamed, and the plan saved."""

    def __init__(self, renamed: RoomRenamed) -> None:
        super().__init__()
        self.renamed = renamed


class MapGrown(Message):
    """The map being built, as far as it goes now; a queue of them collapses into the
    newest."""

    def __init__(self, grid: OccupancyGrid) -> None:
        super().__init__()
        self.grid = grid

    def can_replace(self, message: Message) -> bool:
        return isinstance(message, MapGrown)


class PlanSwitched(Message):
    """The robot plans on another floor plan now (a map saved): drawn and named by it."""

    def __init__(self, plan: FloorPlan, walls: OccupancyGrid | None) -> None:
        super().__init__()
        self.plan = plan
        self.walls = walls


class ControlsChanged(Message):
    """Another console took the controls, or let them go."""

    def __init__(self, controls: Controls) -> None:
        super().__init__()
        self.controls = controls


class Answer(Message):
    """The robot's answer to a request this console made."""

    def __init__(self, request: c.Request, reply: Reply) -> None:
        super().__init__()
        self.request = request
        self.reply = reply


class DaemonLeft(Message):
    """The daemon this console is attached to has gone (service/reattach.py)."""

    def __init__(self, why: str) -> None:
        super().__init__()
        self.why = why


class DaemonBack(Message):
    """Attached again to a daemon, which welcomed the console."""

    def __init__(self, welcome: Welcome) -> None:
        super().__init__()
        self.welcome = welcome
