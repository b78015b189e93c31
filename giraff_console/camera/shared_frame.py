"""The camera's picture for a console in another process (issue 26): small, encoded once.

The daemon has the camera; an attached console draws what it sees at its own pane's
size. What crosses the socket is the processed frame (its overlays drawn: FAST corners,
markers) scaled down to at most SHARED_WIDTH pixels across and JPEG-encoded on the
daemon's side, a few kilobytes: the half-block drawing, which depends on the pane, is
the console's. A console draws at most a couple of hundred cells across, two pixels a
cell down, so nothing it can show is lost.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from giraff_console.camera.feed import CameraPicture
from giraff_console.camera.halfblock import HalfBlockRenderer

# Pixels across a shared frame, and its JPEG quality: about 10 KB a frame at 320x240.
SHARED_WIDTH = 320
JPEG_QUALITY = 75
# A frame larger than this, encoded, is not taken off the socket as one (service/wire.py
# reads whole lines; the daemon never sends one this large at SHARED_WIDTH).
MAX_JPEG_BYTES = 256 * 1024


class SharedFrameError(Exception):
    """A shared frame that cannot be read back as a picture."""


@dataclass(frozen=True)
class SharedFrame:
    """One frame for other consoles: the JPEG, and what the top line says about it."""

    jpeg: bytes
    source: str
    size: tuple[int, int]  # the camera's own, not the shared picture's
    fps: float
    keypoints: int | None = None
    markers: tuple[int, ...] | None = None


def share(image: np.ndarray, source: str, size: tuple[int, int], fps: float,
          keypoints: int | None, markers: tuple[int, ...] | None) -> SharedFrame:  # fmt: skip
    """The processed `image`, scaled down and encoded for the socket."""
    height, width = image.shape[:2]
    if width > SHARED_WIDTH:
        scale = SHARED_WIDTH / width
        image = cv2.resize(image, (SHARED_WIDTH, max(1, round(height * scale))),
                           interpolation=cv2.INTER_AREA)  # fmt: skip
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    if not ok:
        raise SharedFrameError("the frame could not be encoded")
    return SharedFrame(encoded.tobytes(), source, size, fps, keypoints, markers)


def picture_of(frame: SharedFrame, renderer: HalfBlockRenderer,
               cells: tuple[int, int]) -> CameraPicture:  # fmt: skip
    """The frame drawn for a pane of `cells`; SharedFrameError if it is not a JPEG
    within bounds (a garbled or hostile message is refused, not drawn)."""
    if len(frame.jpeg) > MAX_JPEG_BYTES:
        raise SharedFrameError(f"a shared frame of {len(frame.jpeg)} bytes is too large")
    image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise SharedFrameError("a shared frame that is not a picture")
    return CameraPicture(renderer.render(image, *cells), frame.source, frame.size, frame.fps,
                         frame.keypoints, frame.markers)  # fmt: skip
