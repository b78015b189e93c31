"""Asks where the selected robot is to go: a room of the floor plan, completed as it is
typed. Esc leaves without sending anything."""

from __future__ import annotations

from textual import on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.suggester import SuggestFromList
from textual.widgets import Input, Label, Static


class GoScreen(ModalScreen[str | None]):
    """The room's id, or None."""

    DEFAULT_CSS = """
    GoScreen { align: center middle; }
    GoScreen > Vertical {
        width: 70; height: auto; max-height: 80%;
        border: round $accent; padding: 0 1; background: $surface;
    }
    GoScreen #rooms { color: $text-muted; }
    GoScreen #refused { color: $error; }
    """
    BINDINGS = [Binding("escape", "dismiss(None)", "Back", id="go-back")]

    def __init__(self, robot: str, rooms: list[str], *, cursor_blink: bool = True) -> None:
        """`rooms`: the ones it may be sent to; empty if this view does not know its
        plan (the robot refuses a room it does not have, in its state's errors)."""
        super().__init__()
        self.robot = robot
        self.rooms = rooms
        self.cursor_blink = cursor_blink

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Label(f"Send {self.robot} to which room? (Enter sends, Esc leaves)")
            field = Input(placeholder="room id, e.g. kitchen", id="room",
                          suggester=SuggestFromList(self.rooms, case_sensitive=False))  # fmt: skip
            field.cursor_blink = self.cursor_blink
            yield field
            yield Static("", id="refused")
            if self.rooms:
                yield Static("rooms: " + ", ".join(self.rooms), id="rooms")

    @on(Input.Submitted, "#room")
    def _send(self, event: Input.Submitted) -> None:
        room = event.value.strip()
        if not room:
            return
        # A unique beginning is the room it begins: what the suggestion shows.
        starting = [name for name in self.rooms if name.startswith(room)]
        if room not in self.rooms and len(starting) == 1:
            room = starting[0]
        if self.rooms and room not in self.rooms:
            self.query_one("#refused", Static).update(f"no room {room!r} on this plan")
            return
        self.dismiss(room)
