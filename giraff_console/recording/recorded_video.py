"""A recorded session's video as a camera, showing the frame for the playback position.

The frame shown is the last one taken at or before the position, so video, transcript
and pose agree at every moment, at any speed and after any seek (§5.3: "the resulting
visuals and motor odometry should be identical to what was seen when the recording was
first created").
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from giraff_console.camera.source import Frame


class RecordedVideo:
    """A CameraSource reading `camera.mp4` at the position `position()` gives."""

    def __init__(self, path: Path, times: list[float], position: Callable[[], float],
                 clock: Callable[[], float]) -> None:  # fmt: skip
        self.path = path
        self.name = f"recording {path.parent.name}"
        self.times = times
        self.position = position
        self.clock = clock
        self._capture: cv2.VideoCapture | None = None
        self._index = -1  # the frame last decoded
        self._image: np.ndarray | None = None

    def open(self, width: int, height: int) -> tuple[int, int]:
        """Recorded frames come at the size they were recorded at, whatever is asked."""
        self._capture = cv2.VideoCapture(str(self.path))
        self._index, self._image = -1, None
        if not self._capture.isOpened():
            return width, height
        return (
            int(self._capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
            int(self._capture.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        )

    def read(self) -> Frame | None:
        """The frame for the current position; None before the first frame or without video."""
        if self._capture is None or not self._capture.isOpened():
            return None
        wanted = bisect.bisect_right(self.times, self.position()) - 1
        if wanted < 0:
            return None
        if wanted < self._index or wanted > self._index + 30:
            # Backwards, or far ahead: seek rather than decode every frame between.
            self._capture.set(cv2.CAP_PROP_POS_FRAMES, wanted)
            self._index = wanted - 1
        while self._index < wanted:
            ok, image = self._capture.read()
            if not ok:
                # The video ends before its index does (a cut-off recording): hold the last.
                self.times = self.times[: self._index + 1]
                break
            self._index += 1
            self._image = image
        return None if self._image is None else Frame(self._image, self.clock())

    def close(self) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None
