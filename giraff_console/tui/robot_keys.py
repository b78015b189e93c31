"""The console's keys that ask something of the robot: each becomes a request.

A part of the app (GiraffConsole mixes it in). A key does not act on the robot itself:
it posts a request (service/commands.py) to the robot service, in this process or in
the daemon, and the answer comes back to the status log. What a key needs to know of
the robot (is a playback running, is it paused, how high is the stalk) it reads from
the latest telemetry, which comes the same way from either.
"""

from __future__ import annotations

from collections.abc import Callable

from giraff_console.service import commands as c
from giraff_console.service.vocabulary import Intent, Telemetry

# T tilts the head up: the thesis's SetTilt(1), radians from home (B.7).
TILT_UP = 1.0


class RobotKeys:
    """Actions for the driving, head, stalk, recording and playback keys."""

    # Set up by the app; `ask` is KeyGuard's, which the app mixes in after this.
    telemetry: Telemetry | None
    undock_distance: float
    ask: Callable[[str, set[str], Callable[[], None]], None]

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def order(self, request: c.Request) -> None:
        """Post a request to the robot; the app's own is the one used."""
        raise NotImplementedError

    def _playing(self) -> bool:
        telemetry = self.telemetry
        return telemetry is not None and telemetry.playback is not None

    def _live(self) -> bool:
        """Whether commands may go to the robot: not while a session plays back."""
        if self._playing():
            self.note("not sent: playing back, nothing goes to the robot (p returns to live)")
            return False
        return True

    def action_drive(self, intent: str) -> None:
        self.order(c.Press(Intent[intent]))

    def action_halt(self) -> None:
        """Stop now: let go of the keys, and stop any move, typed or undocking, as well."""
        self.order(c.Halt())

    def action_speed(self, step: int) -> None:
        self.order(c.Speed(step=step))

    def action_toggle_poll(self) -> None:
        self.order(c.Poll())

    def action_bulk(self) -> None:
        self.order(c.Send("get bulk_data"))

    # h, t and u move the robot's head or the robot without being held: one stray key
    # must not do it (issue 12), so each asks, and only y does it: the same key again
    # would be a held key's own auto-repeat.

    def action_home_head(self) -> None:
        if self._live():
            self.ask("home the head? y homes it, any other key does not", {"y"},
                     lambda: self.order(c.Send("home")))  # fmt: skip

    def action_tilt(self) -> None:
        if self._live():
            self.ask("tilt the head up? y tilts it, any other key does not", {"y"},
                     lambda: self.order(c.Send(f"set tilt_angle_from_home {TILT_UP}")))  # fmt: skip

    def action_undock(self) -> None:
        if self._live():
            self.ask(f"undock: back out {self.undock_distance:g} m and turn round? "
                     "y goes, any other key does not", {"y"},
                     lambda: self.order(c.Undock()))  # fmt: skip

    def action_stalk(self, steps: int) -> None:
        """g, v: one step up or down from the stalk's last reported height. They do not
        ask first: one press moves the head at most one step (2.5 cm), at the stalk's own
        slow speed, and the wheels not at all (tui/help)."""
        if self._live():
            self.order(c.Stalk(step=steps))

    def action_record(self) -> None:
        recording = self.telemetry is not None and self.telemetry.recording
        self.order(c.Record(on=not recording))

    def action_playback(self) -> None:
        self.order(c.Play(stop=self._playing()))

    def action_pause_playback(self) -> None:
        telemetry = self.telemetry
        playback = telemetry.playback if telemetry is not None else None
        if playback is None:
            self.note("no playback running: p plays the newest session")
            return
        self.order(c.Resume() if playback.paused else c.Pause())

    def action_step_playback(self) -> None:
        self.order(c.Step())

    def action_seek(self, seconds: float) -> None:
        self.order(c.Seek(by=seconds))

    def action_rate(self, factor: float) -> None:
        self.order(c.Rate(times=factor))
