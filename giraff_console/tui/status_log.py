"""The scrolling status log (the thesis's left pane)."""

from __future__ import annotations

import time

from rich.text import Text
from textual.widgets import RichLog

MAX_LINES = 500


class StatusLog(RichLog):
    can_focus = False

    def __init__(self, **kwargs) -> None:
        super().__init__(wrap=True, max_lines=MAX_LINES, markup=False, **kwargs)

    def note(self, text: str, clock_text: str | None = None) -> None:
        stamp = clock_text or time.strftime("%H:%M:%S")
        style = "bold red" if any(word in text for word in ("LOST", "ESTOP", "refused")) else ""
        line = Text(f"{stamp} ", style="dim")
        line.append(text, style=style)
        self.write(line)
