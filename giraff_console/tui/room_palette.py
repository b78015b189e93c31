"""The command palette's robot entries: one "go" per room, the doors, and the robot's
commands that take nothing more (`stop`, `routes`, `status`, ...).

An operator who does not remember a room's id finds it by its label ("Day room") in
the palette (Ctrl+P); picking an entry runs the same typed command as the command line,
from the same table (service/commands.py).
"""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING, cast

from textual.command import DiscoveryHit, Hit, Hits, Provider

from giraff_console.service.commands import TYPED

if TYPE_CHECKING:
    from giraff_console.tui.app import GiraffConsole


class RoomCommands(Provider):
    """`go <room>` for every room, `close`/`open` for every door of the floor plan, and
    the table's commands that are typed alone."""

    def _entries(self) -> list[tuple[str, str]]:
        """(command, help) pairs, rooms first."""
        alone = [(typed.word, typed.help) for typed in TYPED if typed.usage == typed.word]
        navigator = getattr(self.app, "navigator", None)
        if navigator is None:
            return alone
        entries = [
            (f"go {room.id}", f"plan a route to {room.label}")
            for room in sorted(navigator.plan.rooms.values(), key=lambda room: room.label)
        ]
        closed = self._console().closed_doors()
        for door_id in navigator.door_ids():
            verb = "open" if door_id in closed else "close"
            entries.append((f"{verb} {door_id}", f"{verb} the door {door_id} and plan again"))
        return entries + alone

    def _console(self) -> GiraffConsole:
        # Textual types a provider's app as any App; this provider is the console's only.
        return cast("GiraffConsole", self.app)

    async def discover(self) -> Hits:
        console = self._console()
        for command, help_text in self._entries():
            if command.startswith("go "):
                yield DiscoveryHit(command, partial(console.run_command, command), help=help_text)

    async def search(self, query: str) -> Hits:
        matcher = self.matcher(query)
        console = self._console()
        for command, help_text in self._entries():
            # The label is searched too: "day" finds "go day-room (Day room)".
            score = max(matcher.match(command), matcher.match(help_text))
            if score > 0:
                yield Hit(score, matcher.highlight(command),
                          partial(console.run_command, command), help=help_text)  # fmt: skip
