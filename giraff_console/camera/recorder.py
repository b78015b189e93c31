"""Video recording in a background thread with a bounded buffer (§3.4.1, B.3-B.4).

The original encoded in a separate thread with eight buffers, so that the motor loop
never waited for the encoder. Here a full buffer never drops a frame silently: drops
are counted and reported. Each frame's capture time, and the odometry sample nearest
to it, go to a CSV file beside the video, so that camera and motor stay associated
(§3.3.1).
"""

from __future__ import annotations

import csv
import queue
import threading
from dataclasses import dataclass
from pathlib import Path

import cv2

from giraff_console.camera.source import Frame

# The thesis's CAM_REC_BUFFERS (B.3).
BUFFERS = 8


@dataclass(frozen=True)
class RecordedFrame:
    """A frame to record, with the odometry sample (x, y, heading) nearest to it in time."""

    frame: Frame
    odometry: tuple[float, float, float] | None = None


class VideoRecorder:
    """Writes frames to an MP4 (mp4v) file from its own thread."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float = 10.0,
                 buffers: int = BUFFERS) -> None:  # fmt: skip
        self.path = path
        self.size = size
        self.written = 0
        self.dropped = 0
        self.error: str | None = None
        self._writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
        if not self._writer.isOpened():
            raise OSError(f"cannot write video to {path}")
        self._index = path.with_suffix(".frames.csv").open("w", newline="")
        self._csv = csv.writer(self._index)
        self._csv.writerow(["frame", "captured_at", "x", "y", "heading"])
        self._queue: queue.Queue[RecordedFrame | None] = queue.Queue(maxsize=buffers)
        self._thread = threading.Thread(target=self._run, name="video-recorder", daemon=True)
        self._thread.start()

    def submit(self, item: RecordedFrame) -> bool:
        """Queue a frame; False, and one more counted drop, if the buffer is full."""
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            return False
        return True

    def close(self) -> None:
        """Write what is buffered and close the files."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self._writer.release()
        self._index.close()

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            image = item.frame.image
            if (image.shape[1], image.shape[0]) != self.size:
                image = cv2.resize(image, self.size, interpolation=cv2.INTER_AREA)
            try:
                self._writer.write(image)
                odometry = item.odometry or ("", "", "")
                self._csv.writerow([self.written, f"{item.frame.captured_at:.4f}", *odometry])
                self._index.flush()
            except OSError as error:  # a full disk: stop recording, keep everything else
                self.error = f"video recording stopped: {error.strerror or error}"
                return
            self.written += 1
