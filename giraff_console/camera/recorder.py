"""Video recording in a background thread with a bounded buffer (§3.4.1, B.3-B.4).

The original encoded in a separate thread with eight buffers, so that the motor loop
never waited for the encoder. Here a full buffer never drops a frame silently: drops
are counted and reported. Each frame's capture time, and the odometry sample nearest
to it, go to a CSV file beside the video, so that camera and motor stay associated
(§3.3.1).

An MP4 is only readable once closed (its index, the `moov` atom, is written last), so
a kill -9 or a power loss would lose a whole single-file video. The video is therefore
a folder of short segments, each a complete MP4 closed and fsynced after about a
second: a cut loses at most the segment being written. Each segment is named by the
number of its first frame, so a reader can place it without opening the others.
"""

from __future__ import annotations

import contextlib
import csv
import os
import queue
import threading
from dataclasses import dataclass
from pathlib import Path

import cv2

from giraff_console.camera.source import Frame
from giraff_console.private_files import PRIVATE_FOLDER, make_private, open_private

# The thesis's CAM_REC_BUFFERS (B.3).
BUFFERS = 8
# How much video a cut may lose: the segment being written is unreadable until closed.
SEGMENT_SECONDS = 1.0


@dataclass(frozen=True)
class RecordedFrame:
    """A frame to record, with the odometry sample (x, y, heading) nearest to it in time."""

    frame: Frame
    odometry: tuple[float, float, float] | None = None


def segment_path(folder: Path, first_frame: int) -> Path:
    """The segment whose first frame is frame `first_frame` of the recording."""
    return folder / f"{first_frame:06d}.mp4"


def fsync_path(path: Path) -> None:
    """Make a closed file, or a folder's list of files, survive a power loss."""
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


class VideoRecorder:
    """Writes frames as one-second MP4 (mp4v) segments in `folder`, from its own thread.

    The frame index goes to `folder` with the suffix `.frames.csv` (`camera` ->
    `camera.frames.csv`).
    """

    def __init__(self, folder: Path, size: tuple[int, int], fps: float = 10.0,
                 buffers: int = BUFFERS,
                 segment_seconds: float = SEGMENT_SECONDS) -> None:  # fmt: skip
        """Create the folder and the frame index; OSError if that fails."""
        self.path = folder
        self.size = size
        self.fps = fps
        self.segment_seconds = segment_seconds
        self.written = 0
        self.dropped = 0
        self.error: str | None = None
        folder.mkdir(mode=PRIVATE_FOLDER, exist_ok=True)
        self._index = open_private(folder.with_suffix(".frames.csv"), "w", newline="")
        self._csv = csv.writer(self._index)
        self._csv.writerow(["frame", "captured_at", "x", "y", "heading"])
        self._writer: cv2.VideoWriter | None = None
        self._segment: Path | None = None
        self._segment_start = 0.0  # capture time of the open segment's first frame
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
        # Still open if the thread stopped on an error, which is already reported.
        with contextlib.suppress(OSError):
            self._end_segment()
        self._index.close()

    def _run(self) -> None:
        try:
            while (item := self._next()) is not None:
                self._write(item)
                self.written += 1
            self._end_segment()
        except OSError as error:  # a full disk: stop recording, keep everything else
            self.error = f"video recording stopped: {error.strerror or error}"

    def _next(self) -> RecordedFrame | None:
        """The next frame, or None at close.

        A pause in the camera closes the segment, so that its frames do not stay
        unreadable until the next frame comes.
        """
        while True:
            try:
                return self._queue.get(timeout=self.segment_seconds)
            except queue.Empty:
                self._end_segment()

    def _write(self, item: RecordedFrame) -> None:
        captured_at = item.frame.captured_at
        if self._writer is not None and captured_at - self._segment_start >= self.segment_seconds:
            self._end_segment()
        writer = self._writer or self._begin_segment(captured_at)
        image = item.frame.image
        if (image.shape[1], image.shape[0]) != self.size:
            image = cv2.resize(image, self.size, interpolation=cv2.INTER_AREA)
        writer.write(image)
        odometry = item.odometry or ("", "", "")
        self._csv.writerow([self.written, f"{captured_at:.4f}", *odometry])
        self._index.flush()

    def _begin_segment(self, captured_at: float) -> cv2.VideoWriter:
        path = segment_path(self.path, self.written)
        # The same function as cv2.VideoWriter_fourcc, in the spelling the stubs know.
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), self.fps, self.size)
        if not writer.isOpened():
            raise OSError(f"cannot write video to {path}")
        # OpenCV makes the file with the umask's mode (the program's is private, but a
        # caller's may not be): narrowed before a frame of anyone goes into it.
        if path.exists():
            make_private(path)
        self._writer, self._segment, self._segment_start = writer, path, captured_at
        return writer

    def _end_segment(self) -> None:
        """Close the open segment, if any, and fsync it, its folder and the frame index.

        This is the once-a-second fsync: after it, a power loss keeps every frame so far.
        """
        if self._writer is None or self._segment is None:
            return
        self._writer.release()
        segment, self._writer, self._segment = self._segment, None, None
        make_private(segment)  # in case OpenCV made it only as it wrote
        fsync_path(segment)
        fsync_path(self.path)
        os.fsync(self._index.fileno())
