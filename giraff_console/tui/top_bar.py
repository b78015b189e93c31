"""The top line: camera | pose | battery, stalk | performance, with the badges that must
not be missed. The battery and the stalk appear only on boards that report them (later
firmware, wire-facts); on the thesis's board the line is as it always was. Too narrow
for it all, it leaves out the performance's part, then the camera's (bringing the
performance's back if it then fits)."""

from __future__ import annotations

import math

from rich.text import Text
from textual.widgets import Static

from giraff_console.service.vocabulary import (
    Battery,
    ChargeStatus,
    Estimate,
    LinkState,
    MotorState,
    Pose,
    Telemetry,
    head_height,
)

# What the charger's status adds after the percent; not docked says nothing.
_CHARGE_MARKS = {
    ChargeStatus.FAST_CHARGING: "⚡",
    ChargeStatus.TRICKLE_CHARGING: "⚡",
    ChargeStatus.ERROR: "CHARGER ERROR",
    ChargeStatus.INIT: "charger starting",
    ChargeStatus.NOT_DOCKED: "",
}

# The pose when missions would stop and look for a marker, and held keys that do not
# move the robot: hard to miss, and not the red of the alarms (link lost, ESTOP), which
# mean the robot cannot move at all.
_WARNING_STYLE = "bold black on dark_orange"
# The console has lost its daemon: an alarm, like a lost link.
_DISCONNECTED_STYLE = "bold white on red"


class TopBar(Static):
    """One line, like the thesis's SetCameraInfo / SetPositionInfo / SetPerformanceInfo."""

    DEFAULT_CSS = """
    TopBar { height: 1; width: 1fr; background: $panel; }
    """

    def __init__(self, simulator: bool, *, battery_low: float = 25.0, **kwargs) -> None:
        """`battery_low`: below this percent, and not charging, the battery shows LOW."""
        super().__init__(**kwargs)
        self.simulator = simulator
        self.battery_low = battery_low
        self.ui_fps = 0.0
        self.camera = "cam -"
        self.recording = False
        # Attached to a daemon that has gone (service/reattach.py): the last snapshot is
        # not live, and nothing on the line may look as if it were.
        self.disconnected = False
        self._telemetry: Telemetry | None = None
        # The line as last put on screen, and how many times it was: an unchanged line
        # is not put there again (issue 26: twenty repaints a second of the same line).
        self._shown: Text | None = None
        self.updates = 0

    def show_disconnected(self, disconnected: bool) -> None:
        self.disconnected = disconnected
        if self._telemetry is not None:
            self.show(self._telemetry)
        elif disconnected:
            self.update(Text(" DISCONNECTED ", style=_DISCONNECTED_STYLE), layout=False)

    def show_camera(self, text: str) -> None:
        self.camera = text
        if self._telemetry is not None:
            self.show(self._telemetry)

    def show(self, telemetry: Telemetry) -> None:
        self._telemetry = telemetry
        # Narrower than the whole line, the performance's part goes first, then the
        # camera's (80 columns): the pose and the badges stay (issue 26).
        width = self.size.width
        for camera, performance in ((True, True), (True, False), (False, True), (False, False)):
            text = self._line(telemetry, camera, performance)
            if not width or text.cell_len <= width:
                break
        if text == self._shown:
            return
        self._shown = text
        self.updates += 1
        # One line across the screen whatever it says: no new layout of the whole screen
        # twenty times a second (issue 15: most of an idle console's time went to it).
        self.update(text, layout=False)

    def _line(self, telemetry: Telemetry, camera: bool, performance: bool) -> Text:
        text = Text(no_wrap=True, overflow="ellipsis")
        if self.disconnected:
            # The pose last heard, said to be that; no rates, no camera: none is live.
            text.append(" DISCONNECTED ", style=_DISCONNECTED_STYLE)
            text.append(" last heard: ", style="dim")
            text.append(pose_text(telemetry.pose, telemetry.estimate)[0], style="dim")
            text.append(" │ attaching again when the daemon is back", style="dim")
            return text
        for badge, style in self._badges(telemetry):
            text.append(f" {badge} ", style=style)
            text.append(" ")
        if camera:
            text.append(f"{self.camera} │ ", style="dim")
        text.append(*pose_text(telemetry.pose, telemetry.estimate))
        if telemetry.battery is not None:
            text.append(" │ ", style="dim")
            text.append(*battery_text(telemetry.battery, self.battery_low))
        if telemetry.stalk is not None:
            text.append(" │ ", style="dim")
            text.append(stalk_text(telemetry.stalk))
        if performance:
            text.append(f" │ loop {telemetry.loop_hz:.0f} Hz · UI {self.ui_fps:.0f} fps",
                        style="dim")  # fmt: skip
        return text

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
        if telemetry.blocked:
            badges.append(("BLOCKED", _WARNING_STYLE))
        if self.recording:
            badges.append(("● REC", "bold white on dark_red"))
        playback = telemetry.playback
        if playback is not None:
            pace = "paused" if playback.paused else f"{playback.speed:g}x"
            where = f"{clock_time(playback.position)}/{clock_time(math.ceil(playback.duration))}"
            badges.append((f"PLAYBACK {where} {pace}", "bold black on green"))
        return badges


def pose_text(pose: Pose, estimate: Estimate | None) -> tuple[str, str]:
    """`X=12.40±0.03 Y=3.10±0.03 H=90.0±1.2` and its style.

    Each ± is one standard deviation: x's and y's from the covariance's diagonal, the
    heading's in degrees; left out where the estimate has none (a playback without one)
    or no finite one. In a plan with markers, a pose no marker has found yet, or known
    too loosely to drive on, is marked and shown reversed in orange, as missions then
    stop and look (robot/localisation.py `lost`); one a mission slows for is yellow.
    """
    # Rounded before it is wrapped: a heading a hair short of east reads 0.0, not 360.0.
    degrees = round(pose.heading_deg, 1) % 360.0
    x, y, heading = f"X={pose.x:.2f}", f"Y={pose.y:.2f}", f"H={degrees:.1f}"
    if estimate is None:
        return f"{x} {y} {heading}", "bold"
    (xx, _, _), (_, yy, _), _ = estimate.covariance
    x += _plus_minus(_root(xx), 2)
    y += _plus_minus(_root(yy), 2)
    heading += _plus_minus(math.degrees(estimate.sigma_heading), 1)
    text = f"{x} {y} {heading}"
    if estimate.landmarks and not estimate.found:
        return f"{text} (not found)", _WARNING_STYLE
    if estimate.lost:
        return f"{text} (lost)", _WARNING_STYLE
    return text, "bold yellow" if estimate.unsure else "bold"


def _root(variance: float) -> float:
    """The standard deviation of `variance`; NaN for a negative one, which is no spread."""
    return math.sqrt(variance) if variance >= 0 else math.nan


def _plus_minus(sigma: float, decimals: int) -> str:
    return f"±{sigma:.{decimals}f}" if math.isfinite(sigma) else ""


def battery_text(battery: Battery, low: float) -> tuple[str, str]:
    """`BAT 73% ⚡ 25.1 V` and its style: red when low and not charging, or on an error.

    The percent is `--` until the charger has reported W, the voltage left out until B.
    """
    percent = "--" if battery.percent is None else f"{battery.percent:.0f}"
    is_low = battery.percent is not None and battery.percent < low and not battery.charging
    words = [f"BAT {percent}%"]
    mark = "LOW" if is_low else _CHARGE_MARKS[battery.status]
    if mark:
        words.append(mark)
    if battery.voltage is not None:
        words.append(f"{battery.voltage:.1f} V")
    alarm = is_low or battery.status is ChargeStatus.ERROR
    return " ".join(words), "bold white on red" if alarm else "bold"


def stalk_text(stalk: int) -> str:
    """The stalk's setting and the head height it gives: `stalk 520 1.29 m`."""
    return f"stalk {stalk} {head_height(stalk):.2f} m"


def clock_time(seconds: float) -> str:
    """Seconds as m:ss."""
    minutes, seconds = divmod(int(seconds), 60)
    return f"{minutes}:{seconds:02d}"
