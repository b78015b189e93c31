"""The footer: Textual's, with its keys in the console's first frame (issue 26, item 6).

Textual's Footer composes nothing until its screen first says which bindings are active,
and composes its keys after the refresh that follows: the first screen was drawn, then
drawn again only to add the keys, and the robot (started once the screen has been drawn,
tui/app.py `_start`) already ran beside that second drawing. The console's keys are the
app's own (priority bindings; nothing holds the focus at the start, AUTO_FOCUS = None),
so they are known when the footer is composed: it shows them from its first frame.
Textual keeps it up to date from then on as before (Footer.bindings_changed recomposes
it whenever the screen's bindings change).
"""

from __future__ import annotations

from typing import Any

from textual.widgets import Footer


class KeysFooter(Footer):
    """Textual's Footer, its keys composed from the start."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        # Textual's own flag for "the screen has said its bindings" (textual/widgets/
        # _footer.py). A Textual without it draws the keys a refresh later, as before.
        if hasattr(Footer, "_bindings_ready"):
            self.set_reactive(Footer._bindings_ready, True)
