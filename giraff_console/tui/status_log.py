"""The scrolling status log (the thesis's left pane).

A message that arrives again and again (a board error on every tick, 20 a second) shows
once, followed by an ellipsis, a multiplication sign and the count. Otherwise it
would push everything else out of the pane.
"""

from __future__ import annotations

import re

from rich.text import Text
from textual.geometry import Size

from giraff_console.tui.reflow_log import ReflowLog

ALARMS = ("LOST", "ESTOP", "refused", "restarted", "not sent", "internal error")
# The clock time the app puts in front of every line: repeats differ only in it.
_TIME = re.compile(r"\d\d:\d\d:\d\d ")


def message_of(line: str) -> str:
    """The line without its leading clock time."""
    return _TIME.sub("", line, count=1) if _TIME.match(line) else line


class Repeats:
    """Collapses a run of lines with the same message into one line and a count."""

    def __init__(self) -> None:
        self._message: str | None = None
        self.count = 0

    def add(self, line: str) -> tuple[str, bool]:
        """The line to show for `line`, and whether it replaces the last one shown."""
        message = message_of(line)
        if message == self._message:
            self.count += 1
            return f"{line} … \N{MULTIPLICATION SIGN}{self.count}", True
        self._message, self.count = message, 1
        return line, False


class StatusLog(ReflowLog):
    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        self._repeats = Repeats()
        # How many wrapped rows the last line took, and at what width: a resize wraps
        # every line again.
        self._last_rows: int | None = None
        self._rows_width = 0

    def note(self, text: str) -> None:
        """A line; alarms stand out in red; a repeat updates the last line's count."""
        shown, replaces = self._repeats.add(text)
        style = "bold red" if any(word in text for word in ALARMS) else ""
        if replaces and not self._drop_last_line():
            self._lines.pop()
            self.clear()
            for old, old_style in self._lines:
                self.write(Text(old, style=old_style))
        rows_before = len(self.lines) + self._start_line
        self.add_line(shown, style)
        # RichLog defers writes until it knows its size; then the rows are not known.
        self._last_rows = len(self.lines) + self._start_line - rows_before
        self._rows_width = self.size.width
        if not self._size_known:
            self._last_rows = None

    def _drop_last_line(self) -> bool:
        """Remove the last line's rows, cheaply, if they are known; False if not."""
        rows = self._last_rows
        if not rows or rows > len(self.lines) or self.size.width != self._rows_width:
            return False
        self._lines.pop()
        del self.lines[-rows:]
        self._line_cache.clear()
        self.virtual_size = Size(self.virtual_size.width, len(self.lines))
        self.refresh()
        return True
