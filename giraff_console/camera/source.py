"""Where frames come from, behind one small interface (§3.4).

A USB or V4L2 camera through OpenCV, a video file, the synthetic camera of the
simulated world, or a test pattern. When the camera is missing the console falls back
to the synthetic camera (with the simulator) or to the test pattern, as the original
fell back to a test video (§3.4.1).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

# Keys 1-5 of the thesis (B.7 SetResolution); 800x600 is its default (§3.3).
RESOLUTIONS = [(1600, 1200), (1280, 960), (1024, 768), (800, 600), (640, 480)]
DEFAULT_RESOLUTION = (800, 600)


@dataclass(frozen=True)
class Frame:
    """A BGR image and the monotonic time it was captured."""

    image: np.ndarray
    captured_at: float

    @property
    def size(self) -> tuple[int, int]:
        return self.image.shape[1], self.image.shape[0]


class CameraSource(Protocol):
    """A camera: opened at a resolution, read frame by frame."""

    name: str

    def open(self, width: int, height: int) -> tuple[int, int]:
        """Start at (or near) the resolution asked; returns the one actually delivered."""
        ...

    def read(self) -> Frame | None:
        """The next frame, or None when there is none (the device went away)."""
        ...

    def close(self) -> None: ...


class OpenCVCamera:
    """A USB or V4L2 camera by index or device path, or a video file that loops."""

    def __init__(self, device: int | str, clock: Callable[[], float] = time.monotonic) -> None:
        self.device = device
        self.name = f"camera {device}"
        self.clock = clock
        self._capture: cv2.VideoCapture | None = None
        self._loop = isinstance(device, str) and not device.startswith("/dev/")

    def open(self, width: int, height: int) -> tuple[int, int]:
        capture = cv2.VideoCapture(self.device)
        if not capture.isOpened():
            raise OSError(f"cannot open {self.name}")
        if not self._loop:
            capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        self._capture = capture
        return int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(
            capture.get(cv2.CAP_PROP_FRAME_HEIGHT)
        )

    def read(self) -> Frame | None:
        if self._capture is None:
            return None
        ok, image = self._capture.read()
        if not ok and self._loop:
            # A test video plays endlessly, as the original's did (§3.4.1).
            self._capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, image = self._capture.read()
        return Frame(image, self.clock()) if ok else None

    def close(self) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None


class SyntheticCamera:
    """The simulated world seen from a pose, for example the simulator's true pose."""

    name = "synthetic camera"

    def __init__(self, render: Callable[[int, int], np.ndarray],
                 clock: Callable[[], float] = time.monotonic) -> None:  # fmt: skip
        self.render = render
        self.clock = clock
        self._size = DEFAULT_RESOLUTION

    def open(self, width: int, height: int) -> tuple[int, int]:
        self._size = (width, height)
        return self._size

    def read(self) -> Frame | None:
        # Stamped when the view is taken, not once it is drawn: on the simulator's
        # faster clock the drawing's milliseconds would be seconds of driving.
        captured_at = self.clock()
        return Frame(self.render(*self._size), captured_at)

    def close(self) -> None:
        pass


class TestPattern:
    """Colour bars with a moving marker, when there is nothing better to show."""

    name = "test pattern"
    __test__ = False  # not a pytest class

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._size = DEFAULT_RESOLUTION
        self._count = 0

    def open(self, width: int, height: int) -> tuple[int, int]:
        self._size = (width, height)
        return self._size

    def read(self) -> Frame | None:
        width, height = self._size
        bars = np.array(
            [[192, 192, 192], [0, 192, 192], [192, 192, 0], [0, 192, 0],
             [192, 0, 192], [0, 0, 192], [192, 0, 0]], dtype=np.uint8,
        )  # fmt: skip
        columns = (np.arange(width) * len(bars) // width).astype(np.intp)
        image = np.broadcast_to(bars[columns][None, :, :], (height, width, 3)).copy()
        x = (self._count * 8) % max(1, width - 40)
        cv2.rectangle(image, (x, height // 2 - 20), (x + 40, height // 2 + 20), (0, 0, 0), -1)
        self._count += 1
        return Frame(image, self.clock())

    def close(self) -> None:
        pass


def open_camera(
    device: int | str | None, width: int, height: int, synthetic: SyntheticCamera | None
) -> tuple[CameraSource, tuple[int, int], str]:
    """The camera asked for, or the fallback; returns it, its resolution and a note."""
    if device is not None:
        camera = OpenCVCamera(device)
        try:
            size = camera.open(width, height)
            if camera.read() is not None:
                return camera, size, f"{camera.name} at {size[0]}x{size[1]}"
            camera.close()
        except OSError:
            pass
        missing = f"{camera.name} not found; "
    else:
        missing = ""
    fallback: CameraSource = synthetic if synthetic is not None else TestPattern()
    size = fallback.open(width, height)
    return fallback, size, f"{missing}showing the {fallback.name}"
