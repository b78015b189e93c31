"""The top line: camera | pose | performance, with the badges that must not be missed."""

from __future__ import annotations

import math

from rich.text import Text
from textual.widgets import Static

from giraff_console.link import MotorState
from giraff_console.robot.telemetry import LinkState, Telemetry


class TopBar(Static):
    """One line, like the thesis's SetCameraInfo / SetPositionInfo / SetPerformanceInfo."""

    DEFAULT_CSS = """
    TopBar { height: 1; background: $panel; }
    """

    def __init__(self, simulator: bool, **kwargs) -> None:
        super().__init__(**kwargs)
        self.simulator = simulator
        self.ui_fps = 0.0
        self.camera = "cam -"
        self.recording = False
        self._telemetry: Telemetry | None = None

    def show_camera(self, text: str) -> None:
        self.camera = text
        if self._telemetry is not None:
            self.show(self._telemetry)

    def show(self, telemetry: Telemetry) -> None:
        self._telemetry = telemetry
        pose = telemetry.pose
        text = Text(no_wrap=True, overflow="ellipsis")
        for badge, style in self._badges(telemetry):
            text.append(f" {badge} ", style=style)
            text.append(" ")
        text.append(f"{self.camera} │ ", style="dim")
        text.append(f"X={pose.x:.2f} Y={pose.y:.2f} H={pose.heading_deg:.1f}", style="bold")
        text.append(f" │ loop {telemetry.loop_hz:.0f} Hz · UI {self.ui_fps:.0f} fps", style="dim")
        self.update(text)

    def _badges(self, telemetry: Telemetry) -> list[tuple[str, str]]:
        badges = []
        if self.simulator:
            badges.append(("SIMULATOR", "bold black on yellow"))
        if telemetry.link is LinkState.LOST:
            badges.append(("LINK LOST", "bold white on red"))
        state: MotorState | None = telemetry.state
        if state is not None and state.estop:
            badges.append(("ESTOP", "bold white on red"))
        if not telemetry.autopoll:
            badges.append(("POLL OFF", "bold black on cyan"))
        if self.recording:
            badges.append(("● REC", "bold white on dark_red"))
        playback = telemetry.playback
        if playback is not None:
            state = "paused" if playback.paused else f"{playback.speed:g}x"
            where = f"{clock_time(playback.position)}/{clock_time(math.ceil(playback.duration))}"
            badges.append((f"PLAYBACK {where} {state}", "bold black on green"))
        return badges


def clock_time(seconds: float) -> str:
    """Seconds as m:ss."""
    minutes, seconds = divmod(int(seconds), 60)
    return f"{minutes}:{seconds:02d}"
