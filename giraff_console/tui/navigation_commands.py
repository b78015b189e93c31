"""`go <room>`, doors and obstacles from the console (thesis §2.5-§2.7).

A part of the app (GiraffConsole mixes it in). `go` plans (measuring legs on the grid
may take a few hundred milliseconds, so in a worker thread) and hands the mission to the
control loop, which drives it; the map follows from the navigator's state. `close` and
`open` change the plan, and, in the simulator, the building; `block` and `unblock` put
things in the simulated building's way for the range finder to find.
"""

from __future__ import annotations

from collections.abc import Callable

from textual import work
from textual.message import Message

from giraff_console.missions.docking import DOCK
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import NavigationState, Navigator
from giraff_console.planning.room_graph import PlanningError
from giraff_console.protocol import CommandError, parse_number
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.odometry import Pose
from giraff_console.sim_site import SimulatedSite
from giraff_console.tui.messages import NavigationChanged, StatusNote

NAVIGATION_COMMANDS = ("go", "close", "open", "block", "unblock")


class NavigationCommands:
    """Commands for the floor plan; needs the app's control loop, navigator, what its
    missions are built with, simulated site (if any), the robot's pose and
    `post_message`."""

    # Set up by the app.
    control: ControlLoop
    navigator: Navigator | None
    drives: DriveSetup
    site: SimulatedSite | None
    pose: Pose
    post_message: Callable[[Message], bool]

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def _navigation_command(self, word: str, argument: str) -> None:
        navigator = self.navigator
        if word in ("block", "unblock"):
            self._obstacle(word, argument)
            return
        if navigator is None:
            self.note(f"{word}: no floor plan (start the console with --floorplan FILE)")
            return
        if not argument:
            if word == "go":
                self.note(f"usage: go ROOM or go {DOCK}; rooms: {', '.join(navigator.room_ids())}")
            else:
                self.note(f"usage: {word} DOOR; doors: {', '.join(navigator.door_ids())}")
            return
        if word == "go":
            if self.control.playback is not None:
                self.note("go: playing back; p returns to live first")
                return
            self.note(f"planning a route to {argument} ...")
        elif self.site is not None and argument in navigator.door_ids():
            # The simulated building's door too: the range finder will see it.
            (self.site.close_door if word == "close" else self.site.open_door)(argument)
        self._plan(word, argument, self.pose)

    @work(thread=True, exclusive=True, group="planning")
    def _plan(self, word: str, argument: str, pose: Pose) -> None:
        navigator = self.navigator
        assert navigator is not None
        try:
            if word == "go":
                self._go(navigator, argument)
                return
            state = (navigator.close if word == "close" else navigator.open)(argument, pose)
        except PlanningError as error:
            self.post_message(StatusNote(f"{word}: {error}"))
            return
        text = f"door {argument} {'closed' if word == 'close' else 'open'}"
        self.post_message(StatusNote(text + _replanned(state)))
        self.post_message(NavigationChanged(navigator.state))

    def _go(self, navigator: Navigator, room: str) -> None:
        """Plan (PlanningError if there is no way) and let the control loop drive; `go
        dock` drives onto the dock square on."""
        control = self.control
        mission = self.drives.go(room)
        planned = navigator.state.planned
        if planned is not None:
            route = planned.route
            through = ", ".join(route.doors) or "no door"
            self.post_message(StatusNote(
                f"route to {room}: {planned.length_m:.1f} m through {through}; "
                f"{mission.time_optimal:.0f} s at best; Space stops, pause and resume hold it"
            ))  # fmt: skip
        self.post_message(NavigationChanged(navigator.state))

        def ended(why: str) -> None:
            if why == "done":
                navigator.forget()
            self.post_message(NavigationChanged(navigator.state))

        control.run_mission(mission, ended)

    def _obstacle(self, word: str, argument: str) -> None:
        """block X Y / unblock X Y: something in the simulated building's way."""
        if self.site is None:
            self.note(f"{word}: only in the simulator (there is no building to change)")
            return
        try:
            x, y = (float(parse_number(part)) for part in argument.split())
        except (CommandError, ValueError):
            self.note(f"refused: usage: {word} X Y (metres, map frame)")
            return
        if word == "block":
            self.note(f"{self.site.surroundings.block(x, y)} put at ({x:g}, {y:g})")
        else:
            removed = self.site.surroundings.unblock(x, y)
            self.note(f"removed {', '.join(removed)}" if removed else f"nothing at ({x:g}, {y:g})")


def _replanned(state: NavigationState) -> str:
    """What closing or opening a door did to the route, if there is one."""
    if state.goal is None:
        return ""
    if state.planned is None:
        return f"; {state.problem}"
    return f"; route to {state.goal} now {state.planned.length_m:.1f} m"
