"""The command line: raw controller commands and console commands, with history."""

from __future__ import annotations

from textual import events
from textual.binding import Binding
from textual.suggester import SuggestFromList
from textual.widgets import Input

# Parameter names the board knows (A.4), offered as completions.
BOARD_WORDS = [
    "set v ", "set a ", "set r ", "set p ", "set vg ", "set vgr ", "set cdp ", "set mode ",
    "set tilt_angle_from_home ", "get v", "get a", "get r", "get p", "get vg",
    "get vgr", "get cdp", "get mode", "get cang", "get cdis", "get gvr", "get cvg",
    "get tilt_homing_state", "get tilt_angle_from_home", "get but0", "get but1", "get dial",
    "get button_data", "get bulk_data", "home",
    # Later boards (wire-facts "Later firmware").
    "set h ", "get h", "get charger_data",
]  # fmt: skip
CONSOLE_WORDS = [
    "help", "stop", "speed ", "quit", "go ", "record", "teach ", "undock", "stalk ",
]  # fmt: skip


class CommandLine(Input):
    """Hidden until Enter; Escape closes it, Up and Down walk the history.

    While it is open the app hands it every key, in the order typed (`take_key`): none
    reaches a binding of the app, however late the screen catches up (issue 12).
    """

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
            # The focus arrives after keys typed quickly: selecting the text then would
            # let the next key replace what was typed before it.
            select_on_focus=False,
            **kwargs,
        )
        self.history: list[str] = []
        self._position = 0
        self.is_open = False

    def open(self) -> None:
        """Show the line and take the keys from now on.

        `Widget.focus` only queues the change behind the keys already waiting, which a
        busy screen then hands to the app's bindings; `is_open` and the focus change at
        once instead.
        """
        self.is_open = True
        self.display = True
        self.screen.set_focus(self)

    async def take_key(self, key: events.Key) -> str | None:
        """Type `key` into the line now; on Enter, the line's text, sent once: the line
        is cleared and closed before the next key is looked at."""
        if key.key == "enter":
            text = self.value.strip()
            self.remember(text)
            self.action_close()
            return text
        if key.is_printable and key.character is not None:
            selection = self.selection
            if selection.is_empty:
                self.insert_text_at_cursor(key.character)
            else:
                self.replace(key.character, *selection)
            return None
        # Editing keys (arrows, Backspace, Home, Tab, Esc...) run the line's own
        # bindings here, in order, rather than through the focus, which lags under load.
        for binding in self._bindings.key_to_bindings.get(key.key, ()):
            await self.run_action(binding.action)
            break
        return None

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
        self.is_open = False
        self.value = ""
        self.display = False
        self.screen.set_focus(None)
