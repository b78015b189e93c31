"""Recording sessions and playing them back, for the console and the command line alike.

Recording taps the control loop's exchanges and the camera's frames (§3.2.1.1, §3.4.1),
and the pose filter's estimate after each tick (issue 14). Each frame is stored with the
pose nearest to it in time (§3.3.1): the estimate's, which is what the console steered
by and showed; the odometry's own is in the estimates beside it. Playback hands the
control loop a recorded log and its estimates instead of the board, and the camera feed
the recorded video, all following the same playback position.
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from giraff_console.camera.association import SampleHistory
from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.source import CameraSource, Frame
from giraff_console.recording.control_log import LogProblem
from giraff_console.recording.estimates import ESTIMATES
from giraff_console.recording.playback import Playback, frame_times, open_estimates, open_log
from giraff_console.recording.recorded_video import RecordedVideo, session_video
from giraff_console.recording.session import (
    CONTROL_LOG,
    RecordingSetup,
    SessionError,
    SessionRecorder,
    SessionStart,
    read_meta,
)
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.loop_events import ExchangeTap, LoopEvent
from giraff_console.robot.replay import recorded_estimate, session_start
from giraff_console.robot.telemetry import Telemetry

# Problems with a log are listed up to this many; the rest are counted.
SHOWN_PROBLEMS = 5


class Sessions:
    """Starts and stops recordings and playbacks; every outcome goes to `report`."""

    def __init__(self, control: ControlLoop, camera: CameraFeed | None, recordings: Path,
                 setup: RecordingSetup, report: Callable[[str], None]) -> None:  # fmt: skip
        self.control = control
        self.camera = camera
        self.recordings = recordings
        self.setup = setup
        self.report = report
        self.recorder: SessionRecorder | None = None
        # Recordings stop on the UI thread, and on others (a full disk, a patrol's end).
        self._lock = threading.Lock()
        # Set while something must not be disturbed by a playback: a route being taught.
        self.busy: str | None = None
        self._history = SampleHistory()
        self._live_camera: CameraSource | None = None
        self._live_size = (0, 0)
        self._playing: Playback | None = None
        control.subscribe(self._telemetry)

    # -- recording ----------------------------------------------------------------------

    @property
    def recording(self) -> bool:
        return self.recorder is not None

    def start_recording(self) -> Path | None:
        """Start a new session; None, with a message, if it cannot be recorded."""
        if self.control.playback is not None:
            self.report("not recording: a playback is running (`play stop` ends it)")
            return None
        self.stop_recording()
        try:
            recorder = SessionRecorder(
                self.recordings,
                self.setup,
                self.control.clock.now,
                self._recording_failed,
                warn=lambda message: self.report(message),
            )
        except SessionError as error:
            self.report(f"not recording: {error}")
            return None
        self.recorder = recorder

        def begin() -> None:
            # Between two ticks: no poll can come between noting where the odometry
            # stands and recording the next one.
            recorder.begin(session_start(self.control.odometry, recorder.started_at))
            with self._lock:
                if self.recorder is recorder:
                    self.control.subscribe(ExchangeTap(recorder.exchange))

        self.control.between_ticks(begin)
        if self.camera is not None:
            self.camera.taps.append(self._frame)
        self.report(f"recording to {recorder.path}")
        return recorder.path

    def stop_recording(self, only: SessionRecorder | None = None) -> Path | None:
        """Stop and close the recording, if there is one (and it is `only`, if given);
        returns its directory."""
        with self._lock:
            recorder = self.recorder
            if recorder is None or (only is not None and recorder is not only):
                return None
            self.recorder = None
        self._detach(recorder)
        summary = recorder.close()
        self.report(f"recording stopped: {recorder.path} ({summary})")
        return recorder.path

    def snapshot(self, name: str) -> Path | None:
        """The camera's latest frame, saved into the session being recorded; None, with a
        message, if it could not be."""
        recorder = self.recorder
        frame = self.camera.last_frame if self.camera is not None else None
        if recorder is None or frame is None:
            why = "no session is being recorded" if recorder is None else "no camera picture"
            self.report(f"snapshot {name} not taken: {why}")
            return None
        return recorder.snapshot(name, frame)

    def _frame(self, frame: Frame) -> None:
        recorder = self.recorder
        if recorder is not None:
            recorder.frame(frame, self._history.nearest(frame.captured_at))

    def _recording_failed(self, message: str) -> None:
        """The log could not be written: the recording is over, driving goes on.

        Called from the log writer's own thread, which `close` waits for; so the closing
        (the video's last frames, the files) happens on a thread of its own.
        """
        with self._lock:
            recorder, self.recorder = self.recorder, None
        self.report(message)
        if recorder is not None:
            self._detach(recorder)
            threading.Thread(target=recorder.close, name="recording-close", daemon=True).start()

    def _detach(self, recorder: SessionRecorder) -> None:
        # Nothing to undo if it was stopped before it began.
        self.control.unsubscribe(ExchangeTap(recorder.exchange))
        if self.camera is not None:
            with contextlib.suppress(ValueError):
                self.camera.taps.remove(self._frame)

    # -- playback -----------------------------------------------------------------------

    def latest(self) -> Path | None:
        """The newest recorded session, if any: the one that began last. Not the last
        by name, which would be a clone's `sample` (letters sort after digits)."""
        try:
            sessions = [p for p in self.recordings.iterdir() if (p / CONTROL_LOG).is_file()]
        except OSError:
            return None
        return max(sessions, key=lambda p: (began(p), p.name), default=None)

    def start_playback(self, session: Path | None = None) -> Playback | None:
        """Play `session` (a directory, or an original console's log file), else the
        newest one; None, with a message, if there is nothing to play."""
        if self.recorder is not None:
            self.report("not playing: a recording is running (`record stop` ends it)")
            return None
        if self.busy is not None:
            self.report(f"not playing: {self.busy}")
            return None
        session = session or self.latest()
        if session is None:
            self.report(f"nothing to play: no sessions in {self.recordings}")
            return None
        try:
            path, log = open_log(session)
            times = frame_times(session, log)
            meta = read_meta(session) if session.is_dir() else {}
            estimates = open_estimates(session)
        except SessionError as error:
            self.report(f"not playing: {error}")
            return None
        self._report_problems(path, log.problems)
        self._report_problems(session / ESTIMATES, estimates.problems)
        if not log.entries:
            self.report(f"not playing: {path} has no playable lines")
            return None
        clock = self.control.clock
        playback = Playback(session.name, log, clock.now(), start=SessionStart.from_meta(meta),
                            estimates=estimates.entries)  # fmt: skip
        video = session_video(session)
        self._playing = playback
        if self.camera is not None and video is not None:
            source = RecordedVideo(video, times, lambda: playback.position(clock.now()), clock.now)
            shown = self.camera.switch(source)
            if self._live_camera is None:
                # Not when a playback replaces another: back to the camera, not its video.
                self._live_camera, self._live_size = shown, self.camera.size
        elif self._live_camera is not None:
            self._restore_camera()
        self.control.play(playback, lambda: self._ended(playback))
        return playback

    def _report_problems(self, path: Path, problems: Sequence[LogProblem]) -> None:
        for problem in problems[:SHOWN_PROBLEMS]:
            self.report(f"{path}: {problem}")
        if len(problems) > SHOWN_PROBLEMS:
            self.report(f"{path}: {len(problems) - SHOWN_PROBLEMS} more lines skipped")

    def stop_playback(self) -> None:
        """Back to live; the camera follows when the loop has let go of the playback."""
        self.control.stop_playback()

    def _telemetry(self, event: LoopEvent) -> None:
        """After each tick, while recording: the pose steered by, and its estimate."""
        recorder = self.recorder
        if recorder is not None and isinstance(event, Telemetry):
            now = self.control.clock.now()
            # The pose the console steers by and shows: the filter's estimate.
            pose = event.pose
            self._history.add(now, (pose.x, pose.y, pose.heading))
            if event.estimate is not None:
                origin = recorder.started_at
                recorder.estimate(recorded_estimate(event.estimate, now - origin, origin))

    def _ended(self, playback: Playback) -> None:
        """A playback is over; unless another has taken its place, the camera is live."""
        if self._playing is playback:
            self._playing = None
            self._restore_camera()

    def _restore_camera(self) -> None:
        live, self._live_camera = self._live_camera, None
        if live is not None and self.camera is not None:
            self.camera.switch(live)
            # At the resolution it had, not the recording's.
            self.camera.set_resolution(*self._live_size)


def began(session: Path) -> float:
    """When `session` began, in Unix seconds: meta.json's `started_unix`, else when its
    log was last written (an original console's log has no meta.json)."""
    with contextlib.suppress(SessionError):
        # read_meta refuses NaN, Infinity and numbers too large for a float.
        started = read_meta(session).get("started_unix")
        if isinstance(started, int | float) and not isinstance(started, bool):
            return float(started)
    try:
        return (session / CONTROL_LOG).stat().st_mtime
    except OSError:
        return -math.inf
