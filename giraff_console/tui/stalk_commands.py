"""The head's height stalk from the console: `stalk up|down|N` and the keys g and v.

A part of the app (GiraffConsole mixes it in). Later boards raise and lower the head on
a stalk, `h` 0..1000 (robot/stalk.py; wire-facts "Later firmware"). Every change goes to
the board as the typed `set h N` would: through the app's `_board_command`, where the
guard bounds h to 0..1000 (robot/command_guard.py).

The keys do not ask first, unlike h, t and u (issue 12), because a stray press can do
little: the stalk does not move the wheels, one press moves the head at most one step
(2.5 cm) at the stalk's own slow speed, and the step is taken from the last height the
board reported, so a held key (auto-repeat) stays within one step of where the stalk
really is and stops there when let go. A typed `stalk N` is confirmed by Enter.
"""

from __future__ import annotations

from giraff_console.protocol import Command, CommandError, parse_number
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.stalk import STALK_HIGH, STALK_LOW, head_height, stepped
from giraff_console.robot.telemetry import Telemetry

STALK_COMMANDS = ("stalk",)
USAGE = f"usage: stalk up, stalk down or stalk N ({STALK_LOW} to {STALK_HIGH})"


class StalkCommands:
    """`stalk` and its keys; needs the app's control loop, latest telemetry,
    `_live` and `_board_command`."""

    # Set up by the app.
    control: ControlLoop
    telemetry: Telemetry | None

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def _live(self) -> bool:
        """Whether commands may go to the robot; the app's own is the one used."""
        raise NotImplementedError

    def _board_command(self, command: Command) -> None:
        """Check and send a command; the app's own is the one used."""
        raise NotImplementedError

    def action_stalk(self, steps: int) -> None:
        """g, v: one step up or down from the stalk's last reported height."""
        self._stalk_step(steps)

    def _stalk_command(self, argument: str) -> None:
        """stalk up, stalk down, stalk N."""
        if argument in ("up", "down"):
            self._stalk_step(1 if argument == "up" else -1)
            return
        try:
            value = parse_number(argument)
        except CommandError:
            self.note(f"refused: {USAGE}")
            return
        if not isinstance(value, int) or not STALK_LOW <= value <= STALK_HIGH:
            self.note(f"refused: {USAGE}")
            return
        self._stalk_to(value)

    def _stalk_step(self, steps: int) -> None:
        if not self._has_stalk():
            return
        telemetry = self.telemetry
        height = telemetry.stalk if telemetry is not None else None
        if height is None:
            self.note("the stalk's height is not known yet: stalk N sets it")
            return
        target = stepped(height, steps)
        if target == height:
            self.note(f"the stalk is already at its {'top' if steps > 0 else 'bottom'}")
            return
        self._stalk_to(target)

    def _stalk_to(self, target: int) -> None:
        if self._has_stalk() and self._live():
            self.note(f"stalk to {target} (head at {head_height(target):.2f} m)")
            self._board_command(Command("set", "h", target))

    def _has_stalk(self) -> bool:
        """False, and says so, when the board is known to have no stalk. A board not
        yet probed is asked anyway: it answers `Unknown name: h` if it has none."""
        board = self.telemetry.board if self.telemetry is not None else None
        if board is not None and not board.stalk:
            self.note("this board has no height stalk (its firmware does not know h)")
            return False
        return True
