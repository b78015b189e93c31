"""`go <room>`, `close <door>` and `open <door>` from the console (thesis §2.5, §2.6).

A part of the app (GiraffConsole mixes it in): planning measures legs on the grid and
may take a few hundred milliseconds, so it runs in a worker thread, and the new state
comes back to the screen as a message.
"""

from __future__ import annotations

from textual import work

from giraff_console.missions.navigation import NavigationState, Navigator
from giraff_console.planning.room_graph import PlanningError
from giraff_console.robot.odometry import Pose
from giraff_console.tui.messages import NavigationChanged, StatusNote

NAVIGATION_COMMANDS = ("go", "close", "open")


class NavigationCommands:
    """Commands for the floor plan; needs the app's navigator, the robot's pose and
    `post_message`."""

    # Set up by the app.
    navigator: Navigator | None
    pose: Pose

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def _navigation_command(self, word: str, argument: str) -> None:
        navigator = self.navigator
        if navigator is None:
            self.note(f"{word}: no floor plan (start the console with --floorplan FILE)")
            return
        if not argument:
            if word == "go":
                self.note(f"usage: go ROOM; rooms: {', '.join(navigator.room_ids())}")
            else:
                self.note(f"usage: {word} DOOR; doors: {', '.join(navigator.door_ids())}")
            return
        if word == "go":
            self.note(f"planning a route to {argument} ...")
        self._plan(word, argument, self.pose)

    @work(thread=True, exclusive=True, group="planning")
    def _plan(self, word: str, argument: str, pose: Pose) -> None:
        navigator = self.navigator
        assert navigator is not None
        try:
            if word == "go":
                planned = navigator.go(argument, pose)
                route = planned.route
                through = ", ".join(route.doors) or "no door"
                text = (f"route to {argument}: {planned.length_m:.1f} m through {through} "
                        f"({' → '.join(route.rooms)})")  # fmt: skip
            else:
                state = (navigator.close if word == "close" else navigator.open)(argument, pose)
                text = f"door {argument} {'closed' if word == 'close' else 'open'}"
                text += _replanned(state)
        except PlanningError as error:
            self.post_message(StatusNote(f"{word}: {error}"))
            return
        self.post_message(StatusNote(text))
        self.post_message(NavigationChanged(navigator.state))


def _replanned(state: NavigationState) -> str:
    """What closing or opening a door did to the route, if there is one."""
    if state.goal is None:
        return ""
    if state.planned is None:
        return f"; {state.problem}"
    return f"; route to {state.goal} now {state.planned.length_m:.1f} m"
