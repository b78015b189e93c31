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
        table = Table.grid(padding=(0, 1))
        table.add_column(justify="right", style="dim")
        table.add_column()
        pose = telemetry.pose
        table.add_row("pose", f"x {pose.x:.3f}  y {pose.y:.3f}  H {pose.heading_deg:.1f}°")
        if telemetry.link is LinkState.LOST:
            table.add_row("link", Text("LOST: retrying", style="bold red"))
        state = telemetry.state
        if state is not None:
            motion = "moving" if state.moving else "stopped"
            if telemetry.board_r is not None and telemetry.board_r <= 0:
                # Rotating in place: gvr is degrees per second against set p (A.2.2), so
                # counter-clockwise positive, like the heading.
                table.add_row("motion", f"{motion}, turning {state.gvr:+.1f}°/s")
            else:
                speed = "?" if state.speed is None else f"{state.speed:.2f}"
                table.add_row("motion", f"{motion} {speed} m/s vg {state.cvg:.2f}")
            table.add_row("counters", f"cdis {state.cdis:.3f} cang {state.cang:.1f}°")
            if state.tilt is not None:
                table.add_row("head", f"tilt {state.tilt:.3f} rad")
            flags = [name for name, on in (("ESTOP", state.estop), ("abs", state.absolute)) if on]
            table.add_row("mode", " ".join([str(state.mode), *flags]))
        held = telemetry.intent.name.lower().replace("_", "-") if telemetry.intent else "-"
        table.add_row("keys", f"{held}  at {telemetry.speed:.2f} m/s")
        table.add_row("camera", Text("arrives with the camera issue", style="dim italic"))
        self.update(table)
