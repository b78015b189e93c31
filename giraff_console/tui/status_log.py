"""The scrolling status log (the thesis's left pane)."""

from __future__ import annotations

from giraff_console.tui.reflow_log import ReflowLog

ALARMS = ("LOST", "ESTOP", "refused", "restarted", "not sent", "internal error")


class StatusLog(ReflowLog):
    def note(self, text: str) -> None:
        """A line; alarms stand out in red."""
        self.add_line(text, "bold red" if any(word in text for word in ALARMS) else "")
