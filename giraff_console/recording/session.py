"""A recorded session on disk: `recordings/<YYYYmmdd_HHMMSS>/` (§3.2.1.1, §3.8).

- `control.log`: every exchange with the board, in the original's format (control_log).
- `estimate.jsonl`: the pose filter's estimate with its covariance, and the odometry's
  pose beside it (estimates). Sessions recorded before the filter have none.
- `camera/` and `camera.frames.csv`: the video, as one-second MP4 segments that a
  crash cannot spoil, and each frame's capture time and the pose nearest to it, which
  is the filter's estimate (the odometry's in sessions recorded before the filter)
  (camera.recorder). Sessions recorded before the segments have one `camera.mp4`.
- `meta.json`: versions, port, floor plan, camera settings, and when it started, on the
  wall clock and on the monotonic clock the log and frame times are taken from.
- `snapshots/`: JPEG pictures taken on purpose, for example at the stops of a patrol.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2

from giraff_console import __version__
from giraff_console.camera.association import Sample
from giraff_console.camera.recorder import RecordedFrame, VideoRecorder
from giraff_console.camera.source import Frame
from giraff_console.file_limits import read_bounded
from giraff_console.link.exchange import Exchange
from giraff_console.private_files import PRIVATE_FOLDER, open_private, private_folder, write_private
from giraff_console.protocol.kinematics import WHEEL_BASE_M, WHEEL_BASE_RANGE_M
from giraff_console.recording.control_log import entry_for, format_entry
from giraff_console.recording.estimates import (
    ESTIMATE_INTERVAL_S,
    ESTIMATES,
    RecordedEstimate,
    follows,
    format_estimate,
)
from giraff_console.recording.log_writer import LogWriter

CONTROL_LOG = "control.log"
VIDEO = "camera"
# The single-file video of sessions recorded before segments, still played.
SINGLE_FILE_VIDEO = "camera.mp4"
FRAMES = "camera.frames.csv"
META = "meta.json"
SNAPSHOTS = "snapshots"
# The rate the video file declares; frames are placed by their recorded times anyway.
VIDEO_FPS = 10.0
# How the wheels' travel may have been read (robot/wheel_odometers.py), and what
# sessions recorded before later boards were known read.
ODOMETER_READINGS = ("totals", "increments", "encoders")
OLD_SESSIONS_READING = "totals"


@dataclass(frozen=True)
class PoseSample:
    """Where odometry put the robot `offset` seconds into the session."""

    offset: float
    x: float
    y: float
    heading: float  # radians, counter-clockwise from +x


class SessionError(Exception):
    """A session that cannot be recorded or read; the message says why."""


def new_session_dir(root: Path, now: time.struct_time | None = None) -> Path:
    """Create and return `root/<YYYYmmdd_HHMMSS>`, with a suffix if that one exists."""
    stamp = time.strftime("%Y%m%d_%H%M%S", now or time.localtime())
    try:
        # The folder made owner-only if it is made here; one the operator made keeps its
        # mode, and the session in it is theirs alone (private_files.py).
        private_folder(root)
        for attempt in range(1, 100):
            path = root / (stamp if attempt == 1 else f"{stamp}-{attempt}")
            try:
                path.mkdir(mode=PRIVATE_FOLDER)
            except FileExistsError:
                continue
            return path
    except OSError as error:
        raise SessionError(f"cannot create a session in {root}: {error.strerror}") from None
    raise SessionError(f"too many sessions named {stamp} in {root}")


def read_meta(session: Path) -> dict[str, Any]:
    """The session's meta.json; an empty dict if there is none (an original log).
    SessionError for one that cannot be read, is not a regular file (a FIFO would block
    the reader), is larger than the `file_bytes` limit, or is not a JSON object."""
    path = session / META
    if not path.exists():
        return {}
    try:
        meta = json.loads(
            read_bounded(path).decode("utf-8"),
            parse_int=_finite_int,
            parse_float=_finite_float,
            parse_constant=_no_constant,
        )
    except (OSError, ValueError) as error:
        raise SessionError(f"{path}: {str(error)[:200]}") from None
    except RecursionError:
        raise SessionError(f"{path}: nested too deeply") from None
    if not isinstance(meta, dict):
        raise SessionError(f"{path}: not a JSON object")
    return meta


# meta.json's numbers are times and poses: one a float cannot hold (NaN, 1e400, an int
# of 400 digits) is garbage, refused here rather than overflowing where it is used.
def _finite_float(text: str) -> float:
    number = float(text)
    if not math.isfinite(number):
        raise ValueError(f"number out of range: {text[:20]}")
    return number


def _finite_int(text: str) -> int:
    _finite_float(text)
    return int(text)


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _no_constant(text: str) -> float:
    raise ValueError(f"{text} is not a number meta.json may hold")


@dataclass(frozen=True)
class SessionStart:
    """Where the odometry stood as recording began: its pose, and the wheel readings
    (`imdl`, `imdr`, `cvg`, the encoders' `enc0`, `enc1`, taken `offset` seconds into the
    session, so at or before 0) that its next step is taken from. With both, playback
    integrates the first recorded poll exactly as the live console did, even if recording
    began mid-drive. `odometers` and `wheel_base` say how the wheels were read (totals,
    increments or encoders) and turned into a heading, so that playback reads the
    recorded bulk_data as the console did; sessions recorded before they were noted
    read totals, with the thesis's wheel base."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0  # radians, counter-clockwise from +x
    imdl: float | None = None
    imdr: float | None = None
    cvg: float = 0.0
    offset: float = 0.0
    odometers: str = OLD_SESSIONS_READING
    wheel_base: float = WHEEL_BASE_M
    enc0: int | None = None
    enc1: int | None = None

    @classmethod
    def from_meta(cls, meta: dict[str, Any]) -> SessionStart:
        """As meta.json has it; the origin, with no readings, for a log without one."""
        start = meta.get("start")
        if not isinstance(start, dict):
            return cls()
        names = {"x", "y", "heading", "imdl", "imdr", "cvg", "offset", "wheel_base"}
        values: dict[str, Any] = {k: v for k, v in start.items() if k in names}
        if not all(_is_number(v) for v in values.values()):
            return cls()
        low, high = WHEEL_BASE_RANGE_M
        if not low <= values.get("wheel_base", WHEEL_BASE_M) <= high:
            return cls()
        odometers = start.get("odometers", OLD_SESSIONS_READING)
        if odometers not in ODOMETER_READINGS:
            return cls()
        counts = [start.get(name) for name in ("enc0", "enc1")]
        if all(isinstance(c, int) and not isinstance(c, bool) for c in counts):
            values["enc0"], values["enc1"] = counts
        return cls(**values, odometers=odometers)


@dataclass(frozen=True)
class RecordingSetup:
    """What meta.json says about where a session came from."""

    port: str
    floor_plan: str | None = None
    camera: dict[str, Any] | None = None


class SessionRecorder:
    """Records one session: the control log and the estimates at once, the video from the
    first frame.

    `exchange` is a link observer, `estimate` is given the filter's estimate after each
    tick and `frame` is a camera tap; all are called from other threads and return at
    once. A log that cannot be written stops the recording and
    calls `on_error`; video and snapshots that cannot be written call `warn`, and the
    log goes on. Whatever drives the robot goes on undisturbed either way.
    """

    def __init__(self, root: Path, setup: RecordingSetup, clock: Callable[[], float],
                 on_error: Callable[[str], None] = lambda message: None,
                 warn: Callable[[str], None] = lambda message: None) -> None:  # fmt: skip
        """Create the session directory and its log; SessionError if that fails."""
        self.clock = clock
        self.on_error = on_error
        self.warn = warn
        self.path = new_session_dir(root)
        self.started_at = clock()
        self._video: VideoRecorder | None = None
        self._video_failed = False
        self._last_estimate: RecordedEstimate | None = None
        self.meta: dict[str, Any] = {
            "format": 1,
            "giraff_console": __version__,
            "opencv": cv2.__version__,
            "port": setup.port,
            "floor_plan": setup.floor_plan,
            "camera": setup.camera,
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "started_unix": time.time(),
            "clock_origin": self.started_at,
        }
        try:
            self._write_meta()
            self.log = LogWriter(self.path / CONTROL_LOG, self._failed)
        except OSError as error:
            raise SessionError(f"cannot record in {self.path}: {error.strerror}") from None
        try:
            # Without the estimates the session still plays, as one recorded before the
            # filter does: a failure to write them later is only a warning.
            self.estimates = LogWriter(self.path / ESTIMATES, self.warn)
        except OSError as error:
            self.log.close()
            raise SessionError(f"cannot record in {self.path}: {error.strerror}") from None
        self.stopped = False

    def begin(self, start: SessionStart) -> None:
        """Note where the odometry stood as the first exchange is recorded.

        Called on the control loop's thread, so meta.json is written again on another.
        """
        self.meta["start"] = {k: v for k, v in asdict(start).items() if v is not None}
        threading.Thread(target=self._rewrite_meta, name="session-meta", daemon=True).start()

    def _write_meta(self) -> None:
        with open_private(self.path / META, "w", encoding="utf-8") as file:
            file.write(json.dumps(self.meta, indent=2) + "\n")

    def _rewrite_meta(self) -> None:
        try:
            self._write_meta()
        except OSError as error:
            self.warn(f"{self.path / META} not updated: {error.strerror}")

    @property
    def error(self) -> str | None:
        return self.log.error

    def exchange(self, exchange: Exchange) -> None:
        """A link observer: one log line per exchange."""
        entry = entry_for(exchange, self.started_at)
        if entry is not None and not self.stopped:
            self.log.write(format_entry(entry))

    def estimate(self, estimate: RecordedEstimate) -> None:
        """The filter's estimate after a tick: written when playback could not carry the
        last one written along by the odometry, or that one is ESTIMATE_INTERVAL_S old
        (see recording/estimates.py)."""
        last = self._last_estimate
        if self.stopped or not estimate.finite():
            return
        # A microsecond's grace, so that ticks that are 0.2 s apart on paper are.
        if (last is not None and estimate.offset - last.offset < ESTIMATE_INTERVAL_S - 1e-6
                and follows(last, estimate)):  # fmt: skip
            return
        self._last_estimate = estimate
        self.estimates.write(format_estimate(estimate))

    def frame(self, frame: Frame, sample: Sample | None = None) -> None:
        """A camera tap: the frame goes to the video, with its odometry sample."""
        if self.stopped or self._video_failed:
            return
        if self._video is None:
            try:
                self._video = VideoRecorder(self.path / VIDEO, frame.size, VIDEO_FPS)
            except OSError as error:
                self._video_failed = True
                self.warn(f"video not recorded: {error}")
                return
        if self._video.error is not None:
            self._video_failed = True
            self.warn(self._video.error)
            return
        self._video.submit(RecordedFrame(frame, sample))

    def snapshot(self, name: str, frame: Frame) -> Path | None:
        """Save one frame as `snapshots/<name>.jpg`; None, and a message, if it fails."""
        path = self.path / SNAPSHOTS / f"{name}.jpg"
        try:
            path.parent.mkdir(mode=PRIVATE_FOLDER, exist_ok=True)
            ok, data = cv2.imencode(".jpg", frame.image)
            if not ok:
                raise OSError("JPEG encoding failed")
            write_private(path, data.tobytes())
        except OSError as error:
            self.warn(f"snapshot {name} not saved: {error}")
            return None
        return path

    def close(self) -> str:
        """Stop recording and say what was kept."""
        self.stopped = True
        self.log.close()
        self.estimates.close()
        summary = f"{self.log.written} log lines, {self.estimates.written} estimates"
        if self._video is not None:
            self._video.close()
            summary += f", {self._video.written} video frames"
            if self._video.dropped:
                summary += f" ({self._video.dropped} dropped: the disk was too slow)"
        return summary

    def _failed(self, message: str) -> None:
        self.stopped = True
        self.on_error(message)
