"""The help screen: every key and every command, from the same tables the app uses."""

from __future__ import annotations

from rich.table import Table
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Static


class HelpScreen(ModalScreen[None]):
    """Lists the app's bindings and the console's commands; any of Esc, q or ? closes it."""

    DEFAULT_CSS = """
    HelpScreen { align: center middle; }
    HelpScreen > VerticalScroll {
        width: 90%; max-width: 100; height: 90%; border: round $accent; background: $surface;
    }
    """
    BINDINGS = [Binding("escape,q,question_mark", "dismiss", "Close")]
    # Arrows and PgUp/PgDn scroll the list where the terminal is too small for it.
    AUTO_FOCUS = "VerticalScroll"

    def __init__(self, bindings: list[BindingType], commands: list[tuple[str, str]]) -> None:
        super().__init__()
        self.key_bindings = [b for b in bindings if isinstance(b, Binding)]
        self.commands = commands

    def _keys(self, binding: Binding) -> str:
        names = binding.key.split(",")
        return " or ".join(self.app.get_key_display(Binding(name, "")) for name in names)

    def compose(self) -> ComposeResult:
        keys = Table(title="Keys", expand=True, show_edge=False)
        keys.add_column("key", style="bold", no_wrap=True)
        keys.add_column("does")
        for binding in self.key_bindings:
            keys.add_row(self._keys(binding), binding.tooltip or binding.description)
        commands = Table(title="Command line (Enter)", expand=True, show_edge=False)
        commands.add_column("command", style="bold", no_wrap=True)
        commands.add_column("does")
        for name, does in self.commands:
            commands.add_row(name, does)
        with VerticalScroll():
            # The way out first, where it is seen without scrolling.
            yield Static("[dim]Esc, q or ? closes this screen; arrows scroll.[/]")
            yield Static(keys)
            yield Static(commands)
