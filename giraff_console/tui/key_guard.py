"""Where each key goes: the command line, a pending question, or the app's bindings.

Textual hands a key to the focused widget through that widget's own message queue, so
under load (a 2-core robot PC with the control loop busy) keys typed just after Enter
reached the app's bindings before the command line had the focus: typing
`patrol resume` once toggled the poll, recorded, tilted the head and undocked (issue 12).
Here every key is routed as it arrives, in the order typed, before any binding.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from textual import events
from textual.app import App

from giraff_console.clock import Clock
from giraff_console.tui.command_line import CommandLine

# An answer later than this is stale: the operator has moved on, so it is a no.
ANSWER_WITHIN_S = 5.0
# Esc (or q) this soon after the command line closed is the same hand still pressing
# Esc: it asks before quitting, whatever is running.
HASTY_QUIT_S = 1.0


@dataclass(frozen=True)
class Question:
    """A yes/no question that the next key answers: one of `yes` does `then`, any other
    key, or one too late, does nothing."""

    text: str
    yes: frozenset[str]
    asked_at: float
    then: Callable[[], None]


class KeyGuard(App[None]):
    """The app's key routing; the app sets `clock` and `command_line` up."""

    clock: Clock
    command_line: CommandLine
    _question: Question | None = None
    _line_closed_at = -math.inf

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def run_command(self, text: str) -> None:
        """A typed command; the app's own is the one used."""
        raise NotImplementedError

    async def on_event(self, event: events.Event) -> None:
        if isinstance(event, events.Key) and not event.is_forwarded:
            if self._question is not None:
                self._answer(event)
                if event.key != "space":
                    return
                # Space is "no", and still the stop key: it must never be swallowed.
            if self.command_line.is_open:
                text = await self.command_line.take_key(event)
                if not self.command_line.is_open:
                    self._line_closed_at = self.clock.now()
                    self.refresh_bindings()
                if text:
                    self.run_command(text)
                return
            event = lower_case(event)
        await super().on_event(event)

    def open_command_line(self) -> None:
        self.command_line.open()
        self.refresh_bindings()  # the app's keys leave the footer while typing

    def ask(self, text: str, yes: set[str], then: Callable[[], None]) -> None:
        """Ask `text`; a key in `yes` within ANSWER_WITHIN_S seconds does `then`."""
        self._question = Question(text, frozenset(yes), self.clock.now(), then)
        self.note(text)
        self.notify(text, title="confirm", timeout=ANSWER_WITHIN_S)

    def quit_is_hasty(self) -> bool:
        """Whether a quit key came so soon after closing the command line that it may
        be a second Esc meant for the line."""
        return self.clock.now() - self._line_closed_at < HASTY_QUIT_S

    def _answer(self, key: events.Key) -> None:
        question, self._question = self._question, None
        assert question is not None
        self.clear_notifications()
        late = self.clock.now() - question.asked_at > ANSWER_WITHIN_S
        if lower_case(key).key in question.yes and not late:
            question.then()
        else:
            self.note("not done" + (" (answered too late)" if late else ""))


def lower_case(key: events.Key) -> events.Key:
    """A letter typed with Caps Lock or Shift as the letter key itself: every binding
    is a lower-case letter, and an upper-case one used to do nothing."""
    if len(key.key) == 1 and key.key.isupper():
        return events.Key(key.key.lower(), key.key.lower())
    return key
