"""Pose and motion state, in two lines under the camera."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import Static

from giraff_console.robot.telemetry import LinkState, Telemetry


class MainView(Static):
    """The robot's state: motion on one line, odometry and keys on the next."""

    DEFAULT_CSS = """
    MainView { height: 2; padding: 0 1; }
    """

    def show(self, telemetry: Telemetry) -> None:
        state = telemetry.state
        held = telemetry.intent.name.lower().replace("_", "-") if telemetry.intent else "-"
        if telemetry.link is LinkState.LOST:
            motion = Text("LINK LOST: retrying", style="bold red")
        elif state is None:
            motion = Text("no reading yet", style="dim")
        elif telemetry.board_r is not None and telemetry.board_r <= 0:
            # Rotating in place: gvr is degrees per second against set p (A.2.2), so
            # counter-clockwise positive, like the heading.
            moving = "turning" if state.moving else "stopped"
            motion = Text(f"{moving} {state.gvr:+.1f}°/s")
        else:
            speed = "?" if state.speed is None else f"{state.speed:.2f}"
            moving = "moving" if state.moving else "stopped"
            motion = Text(f"{moving} {speed} m/s  vg {round(state.cvg, 2) + 0.0:.2f}")
        if state is not None and state.estop:
            motion.append("  ESTOP", style="bold red")
        detail = Text(style="dim")
        if state is not None:
            detail.append(f"cdis {state.cdis:.3f} cang {state.cang:.1f}° mode {state.mode}  ")
        if telemetry.playback is not None:
            # The keys do not drive while playing back: say which ones do something.
            detail = Text("k pause · . step · j/l ∓10 s · < > speed · p live", style="green")
        else:
            detail.append(f"keys {held} {telemetry.speed:.2f} m/s")
        if telemetry.mission is not None:
            # A mission drives, not the keys: its progress takes their place, whole.
            detail = Text(telemetry.mission, style="bold cyan")
        for line in (motion, detail):
            line.no_wrap, line.overflow = True, "ellipsis"
        self.update(Text("\n").join([motion, detail]))
