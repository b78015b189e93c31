"""A recorded session's video as a camera, showing the frame for the playback position.

The frame shown is the last one taken at or before the position, so video, transcript
and pose agree at every moment, at any speed and after any seek (§5.3: "the resulting
visuals and motor odometry should be identical to what was seen when the recording was
first created").

The video is a folder of MP4 segments, each named by the number of its first frame
(camera.recorder); a session recorded before segments has one `camera.mp4`, read as a
single segment. A segment left unfinished by a crash cannot be opened: the video ends
where it begins.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np

from giraff_console.camera.source import Frame
from giraff_console.recording.session import SINGLE_FILE_VIDEO, VIDEO

# Decoding this many frames forward is cheaper than a seek.
DECODE_AHEAD = 30


def session_video(session: Path) -> Path | None:
    """The session's video, segments or a single file; None without one."""
    for name in (VIDEO, SINGLE_FILE_VIDEO):
        if (session / name).exists():
            return session / name
    return None


def video_segments(video: Path) -> list[tuple[int, Path]]:
    """(number of its first frame, file) for each segment, in order. Regular files only:
    OpenCV's open of a FIFO blocks until a writer comes, and a device never ends."""
    if video.is_file():
        return [(0, video)]
    try:
        files = [path for path in video.iterdir()
                 if path.suffix == ".mp4" and path.stem.isdigit() and path.is_file()]  # fmt: skip
    except OSError:
        return []
    return sorted((int(path.stem), path) for path in files)


def video_frames(video: Path) -> Iterator[tuple[int, np.ndarray]]:
    """Every frame that can be read, with its number, in order."""
    for first, path in video_segments(video):
        capture = cv2.VideoCapture(str(path))
        try:
            number = first
            while True:
                ok, image = capture.read()
                if not ok:
                    break
                yield number, image
                number += 1
        finally:
            capture.release()


class RecordedVideo:
    """A CameraSource reading a session's video at the position `position()` gives."""

    def __init__(self, path: Path, times: list[float], position: Callable[[], float],
                 clock: Callable[[], float]) -> None:  # fmt: skip
        self.path = path
        self.name = f"recording {path.parent.name}"
        self.times = times
        self.position = position
        self.clock = clock
        self._segments: list[tuple[int, Path]] = []
        self._firsts: list[int] = []
        self._part = -1  # the segment open in _capture
        self._capture: cv2.VideoCapture | None = None
        self._index = -1  # the frame last decoded
        self._image: np.ndarray | None = None

    def open(self, width: int, height: int) -> tuple[int, int]:
        """Recorded frames come at the size they were recorded at, whatever is asked."""
        self._segments = video_segments(self.path)
        self._firsts = [first for first, _ in self._segments]
        self._index, self._image = -1, None
        if not self._segments or not self._open_part(0):
            return width, height
        assert self._capture is not None
        return (
            int(self._capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
            int(self._capture.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        )

    def read(self) -> Frame | None:
        """The frame for the current position; None before the first frame or without video."""
        if not self._segments:
            return None
        wanted = bisect.bisect_right(self.times, self.position()) - 1
        if wanted < 0:
            return None
        if wanted != self._index:
            self._decode(wanted)
        return None if self._image is None else Frame(self._image, self.clock())

    def close(self) -> None:
        self._release()
        self._segments, self._firsts = [], []

    def _release(self) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None
        self._part = -1

    def _decode(self, wanted: int) -> None:
        """Decode frame `wanted`, or, if the video ends before it, the last frame there is."""
        while wanted >= 0:
            part = bisect.bisect_right(self._firsts, wanted) - 1
            if part < 0:  # no segment holds the first frames
                self._image = None
                return
            first = self._firsts[part]
            if (part != self._part and not self._open_part(part)) or self._capture is None:
                end = first
            else:
                if wanted < self._index or wanted > self._index + DECODE_AHEAD:
                    # Backwards, or far ahead: seek rather than decode every frame between.
                    self._capture.set(cv2.CAP_PROP_POS_FRAMES, wanted - first)
                    self._index = wanted - 1
                while self._index < wanted:
                    ok, image = self._capture.read()
                    if not ok:
                        break
                    self._index += 1
                    self._image = image
                if self._index == wanted:
                    return
                end = max(first, self._index + 1)
            # The video ends before its index does (a cut-off recording): frames from
            # `end` on cannot be shown, so the index ends there and the last one holds.
            self.times = self.times[:end]
            wanted = end - 1
        self._image = None

    def _open_part(self, part: int) -> bool:
        """Open segment `part` before its first frame; False if it cannot be read."""
        self._release()
        first, path = self._segments[part]
        capture = cv2.VideoCapture(str(path))
        if not capture.isOpened():
            capture.release()
            return False
        self._capture, self._part, self._index = capture, part, first - 1
        return True
