"""The main view. The camera lands in a later issue; until then, pose and motion state."""

from __future__ import annotations

from rich.table import Table
from rich.text import Text
from textual.widgets import Static

from giraff_console.robot.control_loop import LinkState, Telemetry


class MainView(Static):
    """Stands where the camera image will be."""

    DEFAULT_CSS = """
    MainView { content-align: center middle; border: round $primary; }
    """

    def show(self, telemetry: Telemetry) -> None:
        table = Table.grid(padding=(0, 2))
        table.add_column(justify="right", style="dim")
        table.add_column()
        pose = telemetry.pose
        table.add_row(
            "pose", f"x {pose.x:7.3f} m   y {pose.y:7.3f} m   heading {pose.heading_deg:6.1f}°"
        )
        state = telemetry.state
        if telemetry.link is LinkState.LOST:
            table.add_row("link", Text("LOST: retrying", style="bold red"))
        if state is not None:
            motion = "moving" if state.moving else "stopped"
            speed = "  ?  " if state.speed is None else f"{state.speed:5.2f}"
            table.add_row("motion", f"{motion}   speed {speed} m/s   gear {state.cvg:5.2f}")
            table.add_row("counters", f"cdis {state.cdis:7.3f} m   cang {state.cang:7.2f}°")
            if state.tilt is not None:
                table.add_row("head", f"tilt {state.tilt:5.3f} rad from home")
            flags = [
                name for name, on in (("ESTOP", state.estop), ("absolute", state.absolute)) if on
            ]
            table.add_row("mode", f"{state.mode}  {' '.join(flags)}")
        held = telemetry.intent.name.lower().replace("_", "-") if telemetry.intent else "—"
        table.add_row("teleop", f"key {held}   speed setting {telemetry.speed:.2f} m/s")
        table.add_row("", Text("camera: arrives with the camera issue", style="dim italic"))
        self.update(table)
