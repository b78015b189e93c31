"""The scrolling status log (the thesis's left pane)."""

from __future__ import annotations

import collections

from rich.text import Text
from textual.widgets import RichLog

MAX_LINES = 500


class StatusLog(RichLog):
    can_focus = False

    def __init__(self, **kwargs) -> None:
        super().__init__(wrap=True, min_width=16, max_lines=MAX_LINES, markup=False, **kwargs)
        # The notes as written, before wrapping.
        self.messages: collections.deque[str] = collections.deque(maxlen=MAX_LINES)

    def note(self, text: str) -> None:
        """A line, with its leading timestamp dimmed and alarms in red."""
        stamp, _, message = text.partition(" ")
        alarm = any(word in message for word in ("LOST", "ESTOP", "refused", "restarted"))
        line = Text(f"{stamp} ", style="dim")
        line.append(message, style="bold red" if alarm else "")
        self.messages.append(text)
        self.write(line)
