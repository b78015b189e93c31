"""Pose and motion state, in two lines under the camera."""

from __future__ import annotations

from rich.cells import cell_len
from rich.text import Text
from textual import events
from textual.app import ComposeResult
from textual.containers import Horizontal, Vertical
from textual.widgets import Label, ProgressBar, Static

from giraff_console.service.vocabulary import TEXT_BAR, LinkState, Progress, Telemetry

MISSION_STYLE = "bold cyan"
# The ways of showing a mission, widest first: (the part under way on a line of its own,
# the mission's words brief, the part's words brief). The first that fits the view's
# width is used; the last whatever it cuts.
Way = tuple[bool, bool, bool]
ONE_PART: tuple[Way, ...] = ((False, False, False), (False, True, False))
TWO_PARTS: tuple[Way, ...] = (
    (False, False, False),
    (True, False, False),
    (True, True, False),
    (True, True, True),
)
# A bar needs a column and its margin; narrower, it would push the words off the line.
BAR_MIN = 2


class MainView(Vertical):
    """The robot's state: motion on one line, odometry and keys on the next; while a
    mission drives, its progress takes the place of the keys, whole: its name, a bar
    along the plan under way, what it is doing and what is left, and the same again
    for the part under way of a mission made of others (a patrol's stop).

    Where that is wider than the view (80x24 leaves it some 34 columns), the bars shrink
    first; then the part under way goes on a third line; then both say it in brief
    words, what is left first (Progress.words): the ETA stays on screen (issue 26)."""

    DEFAULT_CSS = f"""
    MainView {{ height: 2; padding: 0 1; }}
    MainView > Static {{ height: 1; }}
    MainView > Horizontal {{ height: 1; display: none; }}
    MainView.-two-lines {{ height: 3; }}
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
        self._part = Horizontal()
        # One name, bar and words for the mission, one for the part under way on the same
        # line, and one for it on a line of its own.
        self._names = (Label(), Label(), Label())
        self._bars = tuple(ProgressBar(show_percentage=False, show_eta=False) for _ in range(3))
        self._words = (Label(), Label(), Label())
        self._shown: Progress | None = None
        self._shown_width = 0
        # The two lines as last put on screen: an unchanged line is not put there again
        # (issue 26: the same two lines repainted twenty times a second at rest).
        self._lines: tuple[Text, Text] | None = None
        self.updates = 0

    def compose(self) -> ComposeResult:
        yield self._motion
        yield self._keys
        rows = (self._mission, self._mission, self._part)
        for row, name, bar, words in zip(rows, self._names, self._bars, self._words, strict=True):
            with row:
                yield name
                yield bar
                yield words

    def on_resize(self, event: events.Resize) -> None:
        self._show_mission(self._shown)

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
        width = self.content_region.width
        if progress == self._shown and width == self._shown_width:
            return  # the same at every tick while the robot stands still: no new layout
        self._shown, self._shown_width = progress, width
        self._keys.display = progress is None
        self._mission.display = progress is not None
        part = progress.detail if progress is not None else None
        way, bars = _fitting(progress, width) if progress else (ONE_PART[0], (False, False))
        two_lines, brief, brief_part = way
        self.set_class(two_lines, "-two-lines")
        self._part.display = two_lines
        self._show_part(0, progress, brief, bars[0])
        self._show_part(1, None if two_lines else part, brief_part, bars[1])
        self._show_part(2, part if two_lines else None, brief_part, bars[1])

    def _show_part(self, i: int, part: Progress | None, brief: bool, with_bar: bool) -> None:
        """The mission's (`i` 0) or its part under way's name, bar and words: on the
        mission's line (1), or on a line of its own (2)."""
        name, bar, words = self._names[i], self._bars[i], self._words[i]
        name.display = words.display = part is not None
        bar.display = part is not None and part.total_m is not None and with_bar
        if part is None:
            return
        head, said = _said(part, brief, following=i == 1)
        name.update(_one_line(Text(head, style=MISSION_STYLE)))
        words.update(_one_line(Text(said, style=MISSION_STYLE)))
        if part.total_m is not None:
            bar.update(total=part.total_m, progress=part.done_m or 0.0)


def _said(part: Progress, brief: bool, following: bool) -> tuple[str, str]:
    """A part's name, as it heads its bar or its words, and its words; one `following`
    the mission's words on their line is set off from them."""
    said = part.words(brief)
    head = part.name if part.total_m is not None or not said else f"{part.name}:"
    return (f"· {head}" if following else head), said


def _fitting(progress: Progress, width: int) -> tuple[Way, tuple[bool, bool]]:
    """The first way of showing `progress` whose names and words fit `width` columns on
    every line, and whether the mission's and its part's bars are shown: each takes what
    its line has left, and none is shown on a line with too little left for them all.
    Before the view has a width, the widest; where nothing fits, the briefest, without
    bars."""
    part = progress.detail
    ways = ONE_PART if part is None else TWO_PARTS
    if width <= 0:
        return ways[0], (True, True)
    for way in ways:
        two_lines, brief, brief_part = way
        shown = [(progress, _said(progress, brief, following=False))]
        if part is not None:
            shown.append((part, _said(part, brief_part, following=not two_lines)))
        lines = [shown[:1], shown[1:]] if two_lines else [shown]
        # Each label has a column of margin after it, the last one's included.
        spare = [width + 1 - sum(cell_len(head) + cell_len(said) + 2 for _, (head, said) in line)
                 for line in lines]  # fmt: skip
        if min(spare) < 0:
            continue
        bars: list[bool] = []
        for line, left in zip(lines, spare, strict=True):
            barred = sum(each.total_m is not None for each, _ in line)
            bars += [left >= BAR_MIN * barred] * len(line)
        return way, (bars[0], bars[-1])
    return ways[-1], (False, False)


def _one_line(text: Text) -> Text:
    """`text` on one line, its own style made a span: Textual maps a span's colour names
    through the app's ANSI theme, as in the rest of the console, but reads a Text's own
    style as its own colour names (a brighter red)."""
    line = Text(no_wrap=True, overflow="ellipsis")
    line.append(text)
    return line
