"""Playing a session back as if its commands were being sent (§3.2.1.1, B.2 PlaybackData).

Nothing goes to the robot: the recorded replies are handed out at their recorded times,
to be interpreted as live replies would be, so the transcript, the odometry and the pose
come out as they did when recorded. The playback position runs on the console's clock
at a chosen speed; it can be paused, stepped and moved.

The original stopped its playback loop at every automatic `bulk_data` line, since that
poll followed each camera frame (§3.2.1.1). Frames recorded here carry their own times
(camera.frames.csv), which `frame_times` reads; for a log of the original's, the n-th
automatic poll is the n-th frame.

The pose filter's estimates (estimate.jsonl, recording/estimates.py) go along with the
playback, for the replayer to hand out at their times; a session recorded before the
filter has none.
"""

from __future__ import annotations

import bisect
import csv
import io
import math
import threading
from collections.abc import Sequence
from pathlib import Path

from giraff_console.file_limits import read_bounded
from giraff_console.link.exchange import Exchange, ExchangeKind
from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.replies import parse_reply
from giraff_console.recording.control_log import LogEntry, LogRead, read_log
from giraff_console.recording.estimates import (
    ESTIMATES,
    EstimatesRead,
    RecordedEstimate,
    parse_estimates,
)
from giraff_console.recording.session import (
    CONTROL_LOG,
    FRAMES,
    SessionError,
    SessionStart,
    read_meta,
)

SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
_KINDS: dict[str, ExchangeKind] = {"S": "set", "G": "get", " ": "get", "C": "command"}


def as_exchange(entry: LogEntry, at: float) -> Exchange:
    """The exchange a log entry records, as the link would have reported it at `at`."""
    lines = (entry.reply,) if entry.reply.strip() else ()
    value, error = None, None
    try:
        value = parse_reply(lines).value
    except GiraffError as problem:
        error = problem
    return Exchange(_KINDS[entry.flag], entry.command, lines, value, error, at, at,
                    entry.automatic)  # fmt: skip


def open_log(session: Path) -> tuple[Path, LogRead]:
    """The control log of a session directory, or a log file given directly."""
    path = session
    try:
        path = session / CONTROL_LOG if session.is_dir() else session
        if not path.exists():  # a FIFO or a device is refused by read_log
            raise SessionError(f"no session log at {path}")
        return path, read_log(path)
    except OSError as error:  # unreadable, a name too long, a FIFO, too large...
        raise SessionError(f"cannot read {path}: {error.strerror or error}") from None


def open_estimates(session: Path) -> EstimatesRead:
    """The estimates recorded with `session`: none for a session recorded before the
    pose filter, or for an original console's log file."""
    path = session / ESTIMATES
    try:
        if not session.is_dir() or not path.exists():
            return EstimatesRead([], [])
        data = read_bounded(path, "log_bytes")
    except OSError as error:
        raise SessionError(f"cannot read {path}: {error.strerror or error}") from None
    return parse_estimates(data.decode("utf-8", "replace").split("\n"))


def frame_times(session: Path, log: LogRead) -> list[float]:
    """Each video frame's time into the session, in frame order."""
    meta = read_meta(session) if session.is_dir() else {}
    index = session / FRAMES
    origin = meta.get("clock_origin")
    if isinstance(origin, int | float) and index.is_file():
        times: list[float] = []
        try:
            text = read_bounded(index, "log_bytes").decode("utf-8", "replace")
            for row in csv.DictReader(io.StringIO(text, newline="")):
                time = float(row["captured_at"]) - origin
                if not math.isfinite(time):
                    break
                times.append(time)
        except (OSError, KeyError, TypeError, ValueError, csv.Error):
            # A frame index cut short (a crash mid-row leaves a row with missing fields)
            # or garbled (a NUL, a huge field): the frames before it are still placed right.
            pass
        return times
    return [entry.offset for entry in log.entries if entry.frame_marker]


class Playback:
    """A session log played out against a clock; thread-safe.

    The control loop takes the due entries; the camera asks for the position to pick
    the frame. Times are the console's monotonic clock; positions are seconds into the
    session. `estimates` are the pose filter's, in time order, if the session has them.
    """

    def __init__(self, name: str, log: LogRead, now: float, speed: float = 1.0,
                 start: SessionStart | None = None,
                 estimates: Sequence[RecordedEstimate] = ()) -> None:  # fmt: skip
        self.name = name
        self.start = start or SessionStart()
        self.log = log
        self.entries = log.entries
        self.estimates = tuple(estimates)
        self._offsets = [entry.offset for entry in self.entries]
        self._lock = threading.Lock()
        self._next = 0
        self._speed = speed
        self._paused = False
        # The position is _base_offset at _base_time, and runs on at _speed from there.
        self._base_offset = self.entries[0].offset if self.entries else 0.0
        self._base_time = now

    @property
    def duration(self) -> float:
        return self.log.duration

    @property
    def speed(self) -> float:
        return self._speed

    @property
    def paused(self) -> bool:
        return self._paused

    def position(self, now: float) -> float:
        with self._lock:
            return self._position(now)

    def finished(self, now: float) -> bool:
        """Played to the end; a paused playback waits for the operator, even there."""
        with self._lock:
            return (not self._paused and self._next >= len(self.entries)
                    and self._position(now) >= self.duration)  # fmt: skip

    def due(self, now: float) -> list[LogEntry]:
        """The entries whose time has come since the last call, in order."""
        with self._lock:
            # A microsecond of grace: the time next_due gives must make its entry due,
            # whatever the rounding of position arithmetic.
            end = bisect.bisect_right(self._offsets, self._position(now) + 1e-6, lo=self._next)
            entries = self.entries[self._next : end]
            self._next = end
            return entries

    def next_due(self) -> float | None:
        """The clock time the next entry falls due; None while paused or at the end."""
        with self._lock:
            if self._paused or self._next >= len(self.entries):
                return None
            wait = (self._offsets[self._next] - self._base_offset) / self._speed
            return self._base_time + max(0.0, wait)

    def pause(self, now: float) -> None:
        with self._lock:
            self._rebase(now)
            self._paused = True

    def resume(self, now: float) -> None:
        with self._lock:
            self._rebase(now)
            self._paused = False

    def set_speed(self, now: float, speed: float) -> float:
        """Play at `speed`, clamped to 0.25x-16x; returns the speed set."""
        with self._lock:
            self._rebase(now)
            self._speed = min(max(speed, SPEEDS[0]), SPEEDS[-1])
            return self._speed

    def step(self, now: float) -> float:
        """Pause, and move on to the time of the next entry after the position; returns
        the new position."""
        with self._lock:
            self._rebase(now)
            self._paused = True
            following = bisect.bisect_right(self._offsets, self._base_offset + 1e-6)
            if following < len(self.entries):
                self._base_offset = self._offsets[following]
            return self._base_offset

    def seek(self, now: float, offset: float) -> int:
        """Move to `offset` seconds in; returns how many entries lie up to there.

        Playback cannot undo what it handed out, so the caller rebuilds its picture
        (the pose) from those entries; the next `due` goes on from `offset`.
        """
        with self._lock:
            offset = min(max(offset, 0.0), self.duration)
            self._base_offset, self._base_time = offset, now
            self._next = bisect.bisect_right(self._offsets, offset)
            return self._next

    def _position(self, now: float) -> float:
        if self._paused:
            return self._base_offset
        return self._base_offset + (now - self._base_time) * self._speed

    def _rebase(self, now: float) -> None:
        self._base_offset, self._base_time = self._position(now), now
