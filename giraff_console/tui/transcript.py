"""The controller transcript: commands and decoded replies (the thesis's right pane)."""

from __future__ import annotations

from giraff_console.protocol import format_reply
from giraff_console.service.vocabulary import Exchange
from giraff_console.tui.reflow_log import ReflowLog


class Transcript(ReflowLog):
    """Every command the console sends, except the automatic poll, with its reply.

    Teleop renews the same target many times a second, so identical consecutive
    exchanges are folded into one line with a count.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
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
            self.add_line(f"resynchronised; discarded {len(exchange.lines)} line(s)", "yellow")
            return
        if exchange.kind == "greeting":
            self.add_line("board greeted: " + " / ".join(exchange.lines), "green")
            return
        self.add_line("> " + exchange.command, "bold")
        if exchange.error is not None:
            self.add_line("  " + str(exchange.error), "red")
        for line in exchange.lines:
            decoded = format_reply(line)
            # A list reply reads best one field to a line.
            fields = [field for field in decoded.split(",") if field] if ":" in decoded else []
            for text in fields if len(fields) > 1 else [decoded]:
                self.add_line("  " + text)

    def separator(self, text: str) -> None:
        """A marked break, such as the start of a playback."""
        self._flush_repeats()
        self._last = None
        self.add_line(f"── {text} ──", "green")

    def _flush_repeats(self) -> None:
        if self._repeats:
            self.add_line(f"  … the same {self._repeats} more time(s)", "dim")
        self._repeats = 0
