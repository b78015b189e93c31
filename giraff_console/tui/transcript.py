"""The controller transcript: commands and decoded replies (the thesis's right pane)."""

from __future__ import annotations

import collections

from rich.text import Text
from textual.widgets import RichLog

from giraff_console.link import Exchange
from giraff_console.protocol import format_reply

# The thesis kept this many lines in each scrolling pane (DisplayWindow's BUFFER_SIZE).
MAX_LINES = 500


class Transcript(RichLog):
    """Every command the console sends, except the automatic poll, with its reply.

    Teleop renews the same target many times a second, so identical consecutive
    exchanges are folded into one line with a count.
    """

    can_focus = False

    def __init__(self, **kwargs) -> None:
        super().__init__(wrap=True, min_width=16, max_lines=MAX_LINES, markup=False, **kwargs)
        self._last: tuple[str, tuple[str, ...]] | None = None
        self._repeats = 0
        # The lines as written, before wrapping.
        self.entries: collections.deque[str] = collections.deque(maxlen=MAX_LINES)

    def _line(self, text: str, style: str = "") -> None:
        self.entries.append(text)
        self.write(Text(text, style=style))

    def add(self, exchange: Exchange) -> None:
        if exchange.automatic:
            return
        key = (exchange.command, exchange.lines)
        if key == self._last and exchange.error is None:
            self._repeats += 1
            return
        self._flush_repeats()
        self._last = key
        if exchange.kind == "resync":
            self._line(f"resynchronised; discarded {len(exchange.lines)} line(s)", "yellow")
            return
        if exchange.kind == "greeting":
            self._line("board greeted: " + " / ".join(exchange.lines), "green")
            return
        self._line("> " + exchange.command, "bold")
        if exchange.error is not None:
            self._line("  " + str(exchange.error), "red")
        for line in exchange.lines:
            self._line("  " + format_reply(line))

    def _flush_repeats(self) -> None:
        if self._repeats:
            self._line(f"  … the same {self._repeats} more time(s)", "dim")
        self._repeats = 0
