"""Recording, playback, routes and patrols from the console's keys and command line.

A part of the app (GiraffConsole mixes it in), kept apart for its size: every command
here only calls the headless services (missions.sessions, missions.route_book) and
the control loop, and says what happened in the status log.
"""

from __future__ import annotations

from pathlib import Path

from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.protocol import CommandError, parse_number
from giraff_console.recording.playback import Playback
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.tui.transcript import Transcript

SESSION_COMMANDS = ("record", "play", "pause", "resume", "seek", "rate")
ROUTE_COMMANDS = ("teach", "mark", "done", "routes", "replay-route", "follow-route", "patrol")


class SessionCommands:
    """Actions and commands for sessions and routes; needs the app's services."""

    # Set up by the app.
    control: ControlLoop
    sessions: Sessions | None
    routes: RouteBook | None
    transcript: Transcript

    def note(self, text: str) -> None:
        """A line in the status log; the app's own `note` is the one used."""
        raise NotImplementedError

    def action_record(self) -> None:
        if self.sessions is None:
            self.note("recording is not available")
        elif self.sessions.recording:
            self.sessions.stop_recording()
        else:
            self.sessions.start_recording()

    def action_playback(self) -> None:
        if self.sessions is None:
            self.note("playback is not available")
        elif self.control.playback is not None:
            self.sessions.stop_playback()
        else:
            self._play(None)

    def action_pause_playback(self) -> None:
        playback = self._playback()
        if playback is None:
            return
        now = self.control.clock.now()
        if playback.paused:
            playback.resume(now)
        else:
            playback.pause(now)

    def action_step_playback(self) -> None:
        playback = self._playback()
        if playback is not None:
            playback.step(self.control.clock.now())

    def action_seek(self, seconds: float) -> None:
        playback = self._playback()
        if playback is not None:
            self.control.seek(playback.position(self.control.clock.now()) + seconds)

    def action_rate(self, factor: float) -> None:
        playback = self._playback()
        if playback is not None:
            self._set_rate(playback.speed * factor)

    def _set_rate(self, speed: float) -> None:
        playback = self._playback()
        if playback is not None:
            self.note(f"playback at {playback.set_speed(self.control.clock.now(), speed):g}x")

    def _playback(self) -> Playback | None:
        playback = self.control.playback
        if playback is None:
            self.note("no playback running: p plays the newest session")
        return playback

    def _play(self, session: Path | None) -> None:
        assert self.sessions is not None
        if self.sessions.start_playback(session) is not None:
            self.transcript.separator("playback")

    def _session_command(self, word: str, argument: str) -> None:
        """record [stop], play [DIR|stop], pause, resume, seek SECONDS, rate X."""
        if self.sessions is None and word not in ("pause", "resume"):
            self.note("sessions are not available")
        elif word == "record":
            assert self.sessions is not None  # only pause and resume get this far without sessions
            if argument == "stop":
                self.sessions.stop_recording()
            elif not self.sessions.recording:
                self.sessions.start_recording()
        elif word == "play":
            assert self.sessions is not None  # only pause and resume get this far without sessions
            if argument == "stop":
                self.sessions.stop_playback()
            else:
                try:
                    session = Path(argument).expanduser() if argument else None
                except RuntimeError as error:  # ~nosuchuser
                    self.note(f"not playing: {error}")
                    return
                self._play(session)
        elif word in ("pause", "resume") and (
            self.control.playback is None and self.control.mission is not None
        ):
            self.control.pause_mission(word == "pause")
        elif word in ("pause", "resume"):
            playback = self._playback()
            if playback is not None and word == "pause":
                playback.pause(self.control.clock.now())
            elif playback is not None:
                playback.resume(self.control.clock.now())
        else:
            try:
                value = float(parse_number(argument))
            except CommandError:
                self.note(f"refused: usage: {word} {'12.5' if word == 'seek' else '4'}")
                return
            if word == "seek":
                if self._playback() is not None:
                    self.control.seek(value)
            else:
                self._set_rate(value)

    def _route_command(self, word: str, argument: str) -> None:
        """teach NAME, mark PLACE, done, routes, replay-route NAME, patrol NAME|pause|..."""
        routes = self.routes
        if routes is None:
            self.note("routes are not available")
        elif word == "done":
            routes.done()
        elif word == "routes":
            for line in routes.listing():
                self.note(line)
        elif not argument:
            self.note(f"refused: usage: {word} NAME")
        elif word == "teach":
            routes.teach(argument)
        elif word == "mark":
            routes.mark(argument)
        elif word == "replay-route":
            routes.replay(argument)
        elif word == "follow-route":
            routes.follow(argument)
        elif argument in ("pause", "resume"):
            self.control.pause_mission(argument == "pause")
        elif argument == "stop":
            self.control.stop_mission()
        else:
            routes.patrol(argument)
