"""Pose and motion state, in two lines under the camera."""

from __future__ import annotations

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Horizontal, Vertical
from textual.widgets import Label, ProgressBar, Static

from giraff_console.robot.mission import TEXT_BAR, Progress
from giraff_console.robot.telemetry import LinkState, Telemetry

MISSION_STYLE = "bold cyan"


class MainView(Vertical):
    """The robot's state: motion on one line, odometry and keys on the next; while a
    mission drives, its progress takes the place of the keys, whole: its name, a bar
    along the plan under way, what it is doing and what is left, and the same again
    for the part under way of a mission made of others (a patrol's stop)."""

    DEFAULT_CSS = f"""
    MainView {{ height: 2; padding: 0 1; }}
    MainView > Static {{ height: 1; }}
    MainView > Horizontal {{ height: 1; display: none; }}
    MainView Label {{ margin-right: 1; }}
    MainView ProgressBar {{ margin-right: 1; width: 1fr; max-width: {TEXT_BAR}; }}
    MainView Bar {{ width: 1fr; }}
    MainView Bar > .bar--bar, MainView Bar > .bar--complete {{ color: ansi_cyan; }}
    """

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._motion = Static()
        self._keys = Static()
        self._mission = Horizontal()
        # One name, bar and words for the mission, and one for the part under way.
        self._names = (Label(), Label())
        self._bars = tuple(ProgressBar(show_percentage=False, show_eta=False) for _ in range(2))
        self._words = (Label(), Label())
        self._shown: Progress | None = None
        # The two lines as last put on screen: an unchanged line is not put there again
        # (issue 26: the same two lines repainted twenty times a second at rest).
        self._lines: tuple[Text, Text] | None = None
        self.updates = 0

    def compose(self) -> ComposeResult:
        yield self._motion
        yield self._keys
        with self._mission:
            for name, bar, words in zip(self._names, self._bars, self._words, strict=True):
                yield name
                yield bar
                yield words

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
            moving = "blocked" if telemetry.blocked else "turning" if state.moving else "stopped"
            motion = Text(f"{moving} {state.gvr:+.1f}°/s")
        else:
            speed = "?" if state.speed is None else f"{state.speed:.2f}"
            moving = "blocked" if telemetry.blocked else "moving" if state.moving else "stopped"
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
        self._show_lines(_one_line(motion), _one_line(detail))
        self._show_mission(telemetry.mission)

    def _show_lines(self, motion: Text, detail: Text) -> None:
        """Each line that differs from what is on screen; each a line of its own,
        whatever it says: no layout at every tick."""
        before = self._lines
        self._lines = (motion, detail)
        if before is None or motion != before[0]:
            self._motion.update(motion, layout=False)
            self.updates += 1
        if before is None or detail != before[1]:
            self._keys.update(detail, layout=False)
            self.updates += 1

    def _show_mission(self, progress: Progress | None) -> None:
        """A mission drives, not the keys: its progress takes their place."""
        if progress == self._shown:
            return  # the same at every tick while the robot stands still: no new layout
        self._shown = progress
        self._keys.display = progress is None
        self._mission.display = progress is not None
        self._show_part(0, progress)
        self._show_part(1, progress.detail if progress is not None else None)

    def _show_part(self, i: int, part: Progress | None) -> None:
        """The mission's (`i` 0) or its part under way's name, bar and words."""
        name, bar, words = self._names[i], self._bars[i], self._words[i]
        name.display = words.display = part is not None
        bar.display = part is not None and part.total_m is not None
        if part is None:
            return
        said = part.words()
        head = part.name if part.total_m is not None or not said else f"{part.name}:"
        # The part under way follows on from the mission's words.
        name.update(_one_line(Text(f"· {head}" if i else head, style=MISSION_STYLE)))
        words.update(_one_line(Text(said, style=MISSION_STYLE)))
        if part.total_m is not None:
            bar.update(total=part.total_m, progress=part.done_m or 0.0)


def _one_line(text: Text) -> Text:
    """`text` on one line, its own style made a span: Textual maps a span's colour names
    through the app's ANSI theme, as in the rest of the console, but reads a Text's own
    style as its own colour names (a brighter red)."""
    line = Text(no_wrap=True, overflow="ellipsis")
    line.append(text)
    return line
