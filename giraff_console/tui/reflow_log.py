"""A scrolling log that re-wraps its lines when the pane changes width."""

from __future__ import annotations

import collections

from rich.text import Text
from textual.events import Resize
from textual.widgets import RichLog

# The thesis kept this many lines in each scrolling pane (DisplayWindow's BUFFER_SIZE).
MAX_LINES = 500


class ReflowLog(RichLog):
    """RichLog wraps a line once, when it is written; this one keeps the lines and writes
    them again after a resize, so that nothing stays cut at the old width."""

    can_focus = False

    def __init__(self, **kwargs) -> None:
        super().__init__(wrap=True, min_width=16, max_lines=MAX_LINES, markup=False, **kwargs)
        self._lines: collections.deque[tuple[str, str]] = collections.deque(maxlen=MAX_LINES)
        self._written_width = 0

    @property
    def texts(self) -> list[str]:
        """The lines as written, before wrapping."""
        return [text for text, _ in self._lines]

    def add_line(self, text: str, style: str = "") -> None:
        self._lines.append((text, style))
        self.write(Text(text, style=style))

    def on_resize(self, event: Resize) -> None:
        super().on_resize(event)
        width = event.size.width
        if width and self._written_width and width != self._written_width:
            self.clear()
            for text, style in self._lines:
                self.write(Text(text, style=style))
        self._written_width = width or self._written_width
