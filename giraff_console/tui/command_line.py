"""The command line: raw controller commands and console commands, with history."""

from __future__ import annotations

from textual.binding import Binding
from textual.suggester import SuggestFromList
from textual.widgets import Input

# Parameter names the board knows (A.4), offered as completions.
BOARD_WORDS = [
    "set v ", "set a ", "set r ", "set p ", "set vg ", "set vgr ", "set cdp ", "set mode ",
    "set undock ", "set tilt_angle_from_home ", "get v", "get a", "get r", "get p", "get vg",
    "get vgr", "get cdp", "get mode", "get cang", "get cdis", "get gvr", "get cvg",
    "get tilt_homing_state", "get tilt_angle_from_home", "get but0", "get but1", "get dial",
    "get button_data", "get bulk_data", "home",
]  # fmt: skip
CONSOLE_WORDS = ["help", "stop", "speed ", "quit", "go ", "record", "teach "]


class CommandLine(Input):
    """Hidden until Enter; Escape closes it, Up and Down walk the history."""

    BINDINGS = [
        Binding("escape", "close", "Close", show=False),
        Binding("up", "history(-1)", "Previous", show=False),
        Binding("down", "history(1)", "Next", show=False),
        # Tab takes the suggestion, as in a shell.
        Binding("tab", "cursor_right", "Complete", show=False),
    ]

    def __init__(self, words: list[str] | None = None, **kwargs) -> None:
        """`words` are completions besides the board's and the console's own, such as
        the floor plan's rooms."""
        super().__init__(
            placeholder="controller command (get v, set v 0.3) or console command (help)",
            suggester=SuggestFromList(
                BOARD_WORDS + CONSOLE_WORDS + (words or []), case_sensitive=True
            ),
            **kwargs,
        )
        self.history: list[str] = []
        self._position = 0

    def remember(self, text: str) -> None:
        if text and (not self.history or self.history[-1] != text):
            self.history.append(text)
        self._position = len(self.history)

    def action_history(self, step: int) -> None:
        if not self.history:
            return
        self._position = min(max(self._position + step, 0), len(self.history))
        self.value = self.history[self._position] if self._position < len(self.history) else ""
        self.cursor_position = len(self.value)

    def action_close(self) -> None:
        self.value = ""
        self.display = False
        self.app.set_focus(None)
