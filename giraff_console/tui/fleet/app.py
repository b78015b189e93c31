"""The fleet view: a master control's screen on every robot on a VDA 5050 broker.

A thin front end on fleet/master.py: the table, the map and the log draw the master's
latest snapshot, and the keys call its go, pause, resume, cancel and dock. Nothing in
the robots depends on it; any master control could take its place.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from rich.text import Text
from textual import on
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.timer import Timer
from textual.widgets import DataTable, RichLog, Static

from giraff_console.fleet.master import Fleet, FleetMaster, Refused, Sent
from giraff_console.fleet.vocabulary import ConnectionState
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.tui.fleet.go_screen import GoScreen
from giraff_console.tui.fleet.messages import FleetChanged
from giraff_console.tui.fleet.news import news
from giraff_console.tui.fleet.vehicle_map import VehicleMap
from giraff_console.tui.fleet.vehicle_table import VehicleTable
from giraff_console.tui.keys_footer import KeysFooter
from giraff_console.tui.map_scene import MapScene

# Words that make a log line an alarm, drawn in red.
ALARMS = ("BROKEN", "LOST", "not sent", "FATAL", "bad ")
# The view is drawn again at most this often, whatever comes: a robot says its state at
# every change, and a broker with many driving robots brings several a second each.
REDRAW_S = 0.25


def clock_time() -> str:
    return time.strftime("%H:%M:%S")


class FleetView(App[int]):
    """Every robot the master hears, the selected one on its map, and a log."""

    CSS_PATH = "fleet.tcss"
    TITLE = "giraff-console fleet"
    BINDINGS = [
        Binding("g", "go", "Go", id="go", tooltip="send the robot to a room (an order)"),
        Binding("p", "pause", "Pause", id="pause", tooltip="startPause"),
        Binding("r", "resume", "Resume", id="resume", tooltip="stopPause"),
        Binding("c", "cancel", "Cancel", id="cancel", tooltip="cancelOrder"),
        Binding("d", "dock", "Dock", id="dock", tooltip="an order to the dock, to charge there"),
        Binding("q,ctrl+c", "quit", "Quit", id="quit", tooltip="leave; the robots go on"),
    ]

    def __init__(self, master: FleetMaster, *, plan: FloorPlan | None = None,
                 scene: MapScene | None = None, timestamp: Callable[[], str] = clock_time,
                 cursor_blink: bool = True) -> None:  # fmt: skip
        """`scene`: the plan's still parts to draw the robots on (map_scene.plan_scene);
        `timestamp`: what goes before each log line."""
        super().__init__()
        self.master = master
        self.plan = plan
        self.scene = scene
        self.timestamp = timestamp
        self.cursor_blink = cursor_blink
        self._fleet = Fleet()
        # One FleetChanged on its way at most: a flood of states posts no more.
        self._posted = threading.Event()
        # When the view was last drawn, and the timer that draws it again once REDRAW_S
        # has passed.
        self._drawn_at = -REDRAW_S
        self._later: Timer | None = None

    def compose(self) -> ComposeResult:
        yield Static("", id="fleet-bar")
        yield VehicleTable(id="vehicles")
        with Horizontal(id="below"):
            yield VehicleMap(self.plan, self.scene, id="vehicle-map")
            yield RichLog(id="log", wrap=True, markup=False, min_width=20)
        yield KeysFooter()

    def on_mount(self) -> None:
        self.bar = self.query_one("#fleet-bar", Static)
        self.table = self.query_one(VehicleTable)
        self.vehicle_map = self.query_one(VehicleMap)
        self.log_view = self.query_one(RichLog)
        self.log_view.border_title = "log"
        self.table.focus()
        broker = self.master.broker
        self.note(f"master control on {'mqtts' if broker.tls else 'mqtt'}://"
                  f"{broker.host}:{broker.port}, interface {self.master.interface}")  # fmt: skip
        self.master.watch(self._changed)
        self._refresh_fleet()

    def _changed(self) -> None:
        """On paho's thread: tell the screen, unless it has yet to hear of the last."""
        if not self._posted.is_set():
            self._posted.set()
            self.post_message(FleetChanged())

    def on_fleet_changed(self, message: FleetChanged) -> None:
        wait = self._drawn_at + REDRAW_S - time.monotonic()
        if wait <= 0:
            self._refresh_fleet()
        elif self._later is None:
            self._later = self.set_timer(wait, self._refresh_fleet)

    def _refresh_fleet(self) -> None:
        # Cleared first: a change after this read posts again.
        self._posted.clear()
        self._later, self._drawn_at = None, time.monotonic()
        fleet, before = self.master.fleet(), self._fleet
        if fleet.version == before.version and before.version:
            return
        self._fleet = fleet
        for line in news(before, fleet):
            self.note(line)
        self.table.show(fleet)
        self._show_bar(fleet)
        self._show_selected()

    def _show_bar(self, fleet: Fleet) -> None:
        counts = {state: 0 for state in ConnectionState}
        for vehicle in fleet.vehicles:
            if vehicle.connection is not None:
                counts[vehicle.connection] += 1
        broker = self.master.broker
        link = "connected" if fleet.link_up else "NOT CONNECTED"
        words = (f" broker {broker.host}:{broker.port} {link} · {len(fleet.vehicles)} robots: "
                 f"{counts[ConnectionState.ONLINE]} online, {counts[ConnectionState.OFFLINE]} "
                 f"offline, {counts[ConnectionState.CONNECTIONBROKEN]} broken")  # fmt: skip
        self.bar.update(words)
        self.bar.set_class(not fleet.link_up, "-lost")

    @on(DataTable.RowHighlighted, "#vehicles")
    def _show_selected(self) -> None:
        selected = self.table.selected
        self.vehicle_map.show(self._fleet.get(selected) if selected is not None else None)

    def note(self, line: str) -> None:
        style = "bold red" if any(word in line for word in ALARMS) else ""
        self.log_view.write(Text(f"{self.timestamp()} {line}", style=style))

    def _said(self, result: Sent | Refused) -> None:
        self.note(str(result))

    # The keys.

    def action_go(self) -> None:
        vehicle = self.table.selected
        if vehicle is None:
            return
        known = self._fleet.get(vehicle)
        position = known.state.position if known is not None and known.state else None
        on_plan = self.plan is not None and position is not None and (
            position.map_id == self.plan.name
        )  # fmt: skip
        rooms = sorted(self.plan.rooms) if on_plan and self.plan is not None else []

        def chosen(room: str | None) -> None:
            if room is not None:
                self._said(self.master.go(vehicle, room))

        self.push_screen(GoScreen(vehicle.name, rooms, cursor_blink=self.cursor_blink), chosen)

    def action_pause(self) -> None:
        if (vehicle := self.table.selected) is not None:
            self._said(self.master.pause(vehicle))

    def action_resume(self) -> None:
        if (vehicle := self.table.selected) is not None:
            self._said(self.master.resume(vehicle))

    def action_cancel(self) -> None:
        if (vehicle := self.table.selected) is not None:
            self._said(self.master.cancel(vehicle))

    def action_dock(self) -> None:
        if (vehicle := self.table.selected) is None:
            return
        if self.plan is None or self.plan.start is None:
            self.note(
                f"{vehicle.name}: dock not sent: the floor plan says no start room, "
                "which is where the dock is (--floorplan)"
            )
            return
        self._said(self.master.dock(vehicle, self.plan.start))
