"""The controller transcript: commands and decoded replies (the thesis's right pane)."""

from __future__ import annotations

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
        super().__init__(wrap=True, max_lines=MAX_LINES, markup=False, **kwargs)
        self._last: tuple[str, tuple[str, ...]] | None = None
        self._repeats = 0

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
            note = f"resynchronised; discarded {len(exchange.lines)} line(s)"
            self.write(Text(note, style="yellow"))
            return
        if exchange.kind == "greeting":
            self.write(Text("board greeted: " + " / ".join(exchange.lines), style="green"))
            return
        self.write(Text("> " + exchange.command, style="bold"))
        if exchange.error is not None:
            self.write(Text("  " + str(exchange.error), style="red"))
        for line in exchange.lines:
            self.write(Text("  " + format_reply(line)))

    def _flush_repeats(self) -> None:
        if self._repeats:
            self.write(Text(f"  … the same {self._repeats} more time(s)", style="dim"))
        self._repeats = 0
