"""A row for every robot on the broker: its connection, mode, battery, mission and last
error, redrawn only where a robot changed."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import DataTable

from giraff_console.fleet.master import Fleet, Vehicle
from giraff_console.fleet.topics import VehicleId
from giraff_console.fleet.vocabulary import ConnectionState, ErrorLevel, OperatingMode

# Column keys, headings and widths: fixed, so that the columns hold still as the values
# change, and all of them within a 120-column terminal (each cell has a space either
# side); the log has an error's whole text.
COLUMNS = (
    ("robot", "Robot", 18), ("connection", "Connection", 16), ("mode", "Mode", 9),
    ("battery", "Battery", 7), ("mission", "Mission", 28), ("error", "Last error", 26),
)  # fmt: skip
# Below it the battery is drawn in red: as the console's own low mark (settings, battery.low).
BATTERY_LOW = 25.0
# A robot that cannot be reached is unmissable: the broker said its last will for it.
_BROKEN = "bold white on red"
_CONNECTION_STYLES = {ConnectionState.ONLINE: "green", ConnectionState.OFFLINE: "dim",
                      ConnectionState.CONNECTIONBROKEN: _BROKEN}  # fmt: skip


def cells(vehicle: Vehicle) -> tuple[Text, ...]:
    """The row for `vehicle`; everything but its name dim when it cannot be reached."""
    state, gone = vehicle.state, not vehicle.reachable
    connection = vehicle.connection
    shown = [Text(vehicle.name, style="dim" if gone else "bold")]
    if connection is None:
        shown.append(Text("?", style="dim"))
    else:
        shown.append(Text(connection.value, style=_CONNECTION_STYLES[connection]))
    if state is None:
        shown += [Text("-"), Text("-"), Text("no state yet", style="dim")]
    else:
        shown.append(Text(state.mode.value, style="dark_orange" if state.mode is
                          OperatingMode.MANUAL else ""))  # fmt: skip
        charge = f"{state.battery_charge:.0f}%" + (" ⚡" if state.charging else "")
        shown.append(Text(charge, style="red" if state.battery_charge < BATTERY_LOW else ""))
        shown.append(Text(mission(vehicle)))
    shown.append(last_error(vehicle))
    if gone:
        for cell in shown[2:]:
            cell.stylize("dim")
    return tuple(shown)


def mission(vehicle: Vehicle) -> str:
    """The order: its id, where to, paused or arrived; or the room it waits in."""
    state = vehicle.state
    if state is None:
        return ""
    paused = " PAUSED" if state.paused else ""
    if not state.order_id:
        return f"idle in {state.last_node_id}{paused}"
    if state.target is not None:
        return f"{state.order_id} → {state.target}{paused}"
    if state.arrived:
        return f"{state.order_id} at {state.last_node_id} ✓{paused}"
    return f"{state.order_id} in {state.last_node_id}{paused}"


def last_error(vehicle: Vehicle) -> Text:
    """A message that could not be read first, then the robot's ESTOP, then its errors."""
    if vehicle.problem is not None:
        return Text(str(vehicle.problem), style="red")
    state = vehicle.state
    if state is None:
        return Text("")
    if state.e_stop:
        return Text("ESTOP", style=_BROKEN)
    if not state.errors:
        return Text("")
    error = state.errors[-1]
    return Text(str(error), style="red" if error.level is ErrorLevel.FATAL else "yellow")


class VehicleTable(DataTable[Text]):
    """The robots, by name; `selected` is the one the keys act on."""

    DEFAULT_CSS = """
    VehicleTable { height: 1fr; }
    """

    def __init__(self, **kwargs) -> None:
        super().__init__(cursor_type="row", zebra_stripes=True, **kwargs)
        self._shown: dict[str, tuple[object, ...]] = {}  # what each row reads
        self._ids: dict[str, VehicleId] = {}

    def on_mount(self) -> None:
        for key, heading, width in COLUMNS:
            self.add_column(heading, key=key, width=width)

    @property
    def selected(self) -> VehicleId | None:
        if not self.row_count:
            return None
        key = self.coordinate_to_cell_key(self.cursor_coordinate).row_key.value
        return self._ids.get(key) if key is not None else None

    def show(self, fleet: Fleet) -> None:
        """The rows of `fleet`, changing only those whose robot changed."""
        added = False
        for vehicle in fleet.vehicles:
            name, row = vehicle.name, cells(vehicle)
            # A state repeated at 1 Hz with only its headerId and time new reads alike.
            reads = tuple((cell.plain, str(cell.style), tuple(cell.spans)) for cell in row)
            shown = self._shown.get(name)
            if shown == reads:
                continue
            self._shown[name] = reads
            if shown is None:
                self._ids[name] = vehicle.id
                self.add_row(*row, key=name)
                added = True
            else:
                for (column, _, _), cell in zip(COLUMNS, row, strict=True):
                    self.update_cell(name, column, cell)
        if added:
            self._sort_keeping_selection()

    def _sort_keeping_selection(self) -> None:
        """In order of name, the cursor on the robot it was on."""
        selected = self.selected
        self.sort("robot", key=lambda cell: cell.plain)
        if selected is not None:
            self.move_cursor(row=self.get_row_index(selected.name))
