"""Listening to the control loop in tests: one kind of its events, or its notes' text."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from giraff_console.robot.loop_events import Listener, LoopEvent, Note

Event = TypeVar("Event", bound=LoopEvent)


def only(kind: type[Event], then: Callable[[Event], object]) -> Listener:
    """A listener that hands the events of `kind` alone to `then`."""

    def listen(event: LoopEvent) -> None:
        if isinstance(event, kind):
            then(event)

    return listen


def notes_into(texts: list[str]) -> Listener:
    """A listener that keeps the text of every note in `texts`."""
    return only(Note, lambda note: texts.append(note.text))
