"""Where frames come from, behind one small interface (§3.4).

A USB or V4L2 camera through OpenCV, a video file, a camera served on a Unix socket
(the out-of-process simulator's, `sim --camera`), the synthetic camera of the
simulated world, or a test pattern. When the camera is missing the console falls back
to the synthetic camera (with the simulator) or to the test pattern, as the original
fell back to a test video (§3.4.1).
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np

from giraff_console.camera.socket_wire import (
    REPLY,
    CameraWireError,
    ReplyStatus,
    check_size,
    decode_reply,
    encode_request,
)

# Keys 1-5 of the thesis (B.7 SetResolution); 800x600 is its default (§3.3).
RESOLUTIONS = [(1600, 1200), (1280, 960), (1024, 768), (800, 600), (640, 480)]
DEFAULT_RESOLUTION = (800, 600)
# `--camera unix:PATH`: a camera served on a Unix socket.
SOCKET_SCHEME = "unix:"
# The longest a socket camera may take to connect, or to answer a frame: a frame of the
# simulator's takes 15 to 30 ms to draw, and it draws one at a time for a few clients.
SOCKET_TIMEOUT_S = 1.0


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


class SocketCamera:
    """A camera served on a Unix socket (camera/socket_wire.py): the simulator's
    synthetic camera in another process, `giraff-console sim --camera PATH`.

    Each frame is asked for, then read. It is stamped with the console's clock when it
    is asked for, which is when the simulator takes the pose it draws, as a triggered
    camera's driver stamps the trigger: not when it arrives, 15 to 30 ms of drawing
    later, which at 0.4 m/s would put the markers a centimetre behind.

    A socket that goes away, a server that refuses, a reply that is not the format or
    that takes longer than `timeout` to come: `read` returns None, as a camera that
    went away does, and connects again at the next read (a simulator started again)."""

    def __init__(self, path: str, clock: Callable[[], float] = time.monotonic,
                 timeout: float = SOCKET_TIMEOUT_S) -> None:  # fmt: skip
        self.path = path
        self.name = f"camera {SOCKET_SCHEME}{path}"
        self.clock = clock
        self.timeout = timeout
        self._size = DEFAULT_RESOLUTION
        self._opened = False
        self._socket: socket.socket | None = None

    def open(self, width: int, height: int) -> tuple[int, int]:
        """The simulator draws any size from 16 to 4096 px a side (CameraWireError for
        others), so the size asked for is the size delivered. It connects at the first
        read: a camera feed opens its camera again on every change of resolution, and a
        simulator that is not there must not end the feed."""
        check_size(width, height)
        self._hang_up()
        self._size = (width, height)
        self._opened = True
        return self._size

    def read(self) -> Frame | None:
        if not self._opened:
            return None
        deadline = time.monotonic() + self.timeout
        try:
            if self._socket is None:
                self._socket = self._connect()
            return self._exchange(self._socket, deadline)
        except (OSError, CameraWireError):
            self._hang_up()
            return None

    def close(self) -> None:
        self._opened = False
        self._hang_up()

    def _connect(self) -> socket.socket:
        connection = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        connection.settimeout(self.timeout)
        try:
            connection.connect(self.path)
        except OSError:
            connection.close()
            raise
        return connection

    def _exchange(self, connection: socket.socket, deadline: float) -> Frame:
        """Ask for a frame and read it, by `deadline`."""
        width, height = self._size
        captured_at = self.clock()
        connection.settimeout(max(deadline - time.monotonic(), 1e-3))
        connection.sendall(encode_request(width, height))
        header = _receive_exactly(connection, memoryview(bytearray(REPLY.size)), deadline)
        reply = decode_reply(bytes(header))
        if reply.status is ReplyStatus.REFUSED:
            reason = _receive_exactly(connection, memoryview(bytearray(reply.length)), deadline)
            raise CameraWireError(f"refused: {bytes(reason).decode('utf-8', 'replace')}")
        if (reply.width, reply.height) != (width, height):
            raise CameraWireError(f"{self.name} sent {reply.width}x{reply.height}, not "
                                  f"{width}x{height}")  # fmt: skip
        image = np.empty((height, width, 3), dtype=np.uint8)
        _receive_exactly(connection, image.data.cast("B"), deadline)
        return Frame(image, captured_at)

    def _hang_up(self) -> None:
        if self._socket is not None:
            with contextlib.suppress(OSError):
                self._socket.close()
            self._socket = None


def _receive_exactly(connection: socket.socket, into: memoryview, deadline: float) -> memoryview:
    """Fill `into` from the socket by `deadline`; OSError (TimeoutError, or a connection
    reset for a server that closed) if it cannot."""
    got = 0
    while got < len(into):
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError("the camera did not answer in time")
        connection.settimeout(remaining)
        count = connection.recv_into(into[got:])
        if count == 0:
            raise ConnectionResetError("the camera closed the connection")
        got += count
    return into


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


def camera_for(device: int | str, clock: Callable[[], float] = time.monotonic) -> CameraSource:
    """The camera `--camera` names: `unix:PATH`, one served on a Unix socket (the
    simulator's, `sim --camera PATH`); a number, a USB or V4L2 camera by index; anything
    else, a device path or a video file."""
    if isinstance(device, str) and device.startswith(SOCKET_SCHEME):
        return SocketCamera(device.removeprefix(SOCKET_SCHEME), clock)
    if isinstance(device, str) and device.isdigit():
        device = int(device)
    return OpenCVCamera(device, clock)


def open_camera(
    device: int | str | None, width: int, height: int, synthetic: SyntheticCamera | None,
    clock: Callable[[], float] = time.monotonic,
) -> tuple[CameraSource, tuple[int, int], str]:  # fmt: skip
    """The camera asked for (see `camera_for`), its frames stamped by `clock`, or the
    fallback; returns it, its resolution and a note."""
    if device is not None:
        camera = camera_for(device, clock)
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
