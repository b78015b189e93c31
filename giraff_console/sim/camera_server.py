"""The synthetic camera on a Unix socket, for a console in another process.

`giraff-console sim --pty --floorplan PLAN --camera PATH` serves the board on a pty and,
here, what a camera on the robot would see: the building drawn from the robot's true
pose at the moment each frame is asked for. A real robot's camera is a device only its
own user can open; so is this socket (0600, in a folder not every user may write to,
so not /tmp itself), and it is never on the network. The wire format is sim/camera_wire.py's.

The board's pty must never wait for a picture: frames are served from threads of their
own, one per client and a few clients at most, the board's lock held only for the moment
the pose is read. Every wait is bounded: a client that says nothing for `IDLE_S`, or
stops reading a frame for `SEND_TIMEOUT_S`, is dropped.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import stat
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.camera_calibration import write_calibration
from giraff_console.sim.camera_wire import (
    REQUEST,
    FrameRequestError,
    decode_request,
    encode_frame_header,
    encode_refusal,
)
from giraff_console.sim.drive import TruePose

# A console and a daemon watching, and a test or two: more is a leak.
MAX_CLIENTS = 4
# A client that asks for nothing this long is dropped; a console reconnects when it asks.
IDLE_S = 10.0
# A whole frame (1.4 MB at 800x600) to a client that reads; one that does not is dropped.
SEND_TIMEOUT_S = 2.0
# One picture drawn at a time, at most this many a second for all clients together, as a
# real camera delivers at its own rate however many read it: the simulator keeps a core.
MAX_FRAMES_PER_S = 30.0
# sockaddr_un's sun_path holds 108 bytes, the terminating NUL included.
MAX_PATH_BYTES = 107
CALIBRATION_SUFFIX = ".calibration.yaml"


class CameraServerError(OSError):
    """The socket cannot be served at the path asked for; the message says why."""


class CameraServer:
    """Serves `camera`'s view from `pose()` on a Unix socket at `path`, and writes the
    camera's calibration beside it (`calibration_path`), until `close`."""

    def __init__(self, path: Path, camera: WorldCamera, pose: Callable[[], TruePose]) -> None:
        self.path = Path(os.path.abspath(path))
        self.calibration_path = self.path.with_name(self.path.name + CALIBRATION_SUFFIX)
        self.camera = camera
        self.pose = pose
        self._listener = _listen(self.path)
        info = os.lstat(self.path)
        self._identity = (info.st_dev, info.st_ino)
        try:
            write_calibration(self.calibration_path, camera)
        except OSError as error:
            self._listener.close()
            self._remove_socket()
            raise CameraServerError(
                f"cannot write the camera's calibration {self.calibration_path}: "
                f"{error.strerror or error}"
            ) from None
        self._stopping = threading.Event()
        # Wakes the acceptor out of its wait when stopping.
        self._wake_read, self._wake_write = socket.socketpair()
        self._clients: dict[socket.socket, threading.Thread] = {}
        self._clients_lock = threading.Lock()
        self._render_lock = threading.Lock()
        self._next_render = 0.0
        self._acceptor = threading.Thread(target=self._accept, name="camera-accept", daemon=True)

    def start(self) -> None:
        self._acceptor.start()

    def close(self) -> None:
        """Stop serving, drop every client, remove the socket and the calibration."""
        self._stopping.set()
        with contextlib.suppress(OSError):
            self._wake_write.send(b"!")
        if self._acceptor.is_alive():
            self._acceptor.join(timeout=SEND_TIMEOUT_S)
        with self._clients_lock:
            clients = list(self._clients.items())
        for connection, _ in clients:
            # Wakes its thread out of a receive or a send at once.
            with contextlib.suppress(OSError):
                connection.shutdown(socket.SHUT_RDWR)
        for _, thread in clients:
            thread.join(timeout=SEND_TIMEOUT_S)
        self._listener.close()
        self._wake_read.close()
        self._wake_write.close()
        self._remove_socket()
        with contextlib.suppress(FileNotFoundError):
            self.calibration_path.unlink()

    def _remove_socket(self) -> None:
        """Unlink the socket if it is still ours: another simulator may have replaced a
        socket it took for a stale one."""
        with contextlib.suppress(FileNotFoundError):
            info = os.lstat(self.path)
            if (info.st_dev, info.st_ino) == self._identity:
                self.path.unlink()

    def _accept(self) -> None:
        while not self._stopping.is_set():
            readable, _, _ = select.select([self._listener, self._wake_read], [], [])
            if self._wake_read in readable:
                return
            try:
                connection, _ = self._listener.accept()
            except OSError:
                continue  # the client left before it was accepted
            with self._clients_lock:
                full = len(self._clients) >= MAX_CLIENTS
                if not full:
                    thread = threading.Thread(target=self._serve, args=(connection,),
                                              name="camera-client", daemon=True)  # fmt: skip
                    self._clients[connection] = thread
            if full:
                _refuse(connection, f"busy: {MAX_CLIENTS} clients are watching already")
                continue
            thread.start()

    def _serve(self, connection: socket.socket) -> None:
        """One client's requests, each answered with a frame, until it leaves, idles,
        stops reading or asks for something this camera does not give."""
        try:
            while not self._stopping.is_set():
                request = _receive(connection, REQUEST.size, time.monotonic() + IDLE_S)
                if request is None:
                    return
                try:
                    width, height = decode_request(request)
                except FrameRequestError as error:
                    _refuse(connection, str(error))
                    return
                # The pose when it was asked for, however long the picture waits its turn:
                # the client stamps the frame with the time it asked.
                pose = self.pose()
                image = self._render(pose, width, height)
                if image is None:
                    return
                connection.settimeout(SEND_TIMEOUT_S)  # for the whole frame, not per send
                connection.sendall(b"".join((encode_frame_header(width, height), image.data)))
        except OSError:
            pass  # gone, or too slow to read: dropped
        finally:
            with self._clients_lock:
                self._clients.pop(connection, None)
            connection.close()

    def _render(self, pose: TruePose, width: int, height: int) -> np.ndarray | None:
        """The picture, once it is this client's turn; None if the server is stopping."""
        with self._render_lock:
            wait = self._next_render - time.monotonic()
            if wait > 0 and self._stopping.wait(wait):
                return None
            self._next_render = time.monotonic() + 1.0 / MAX_FRAMES_PER_S
            image = self.camera.render(pose, width, height)
        return np.ascontiguousarray(image, dtype=np.uint8).reshape(height, width, 3)


def _listen(path: Path) -> socket.socket:
    """A listening socket at `path` that only this user can connect to; see the module
    docstring. CameraServerError for a path that cannot be served safely."""
    if len(os.fsencode(path)) > MAX_PATH_BYTES:
        raise CameraServerError(f"{path}: too long for a Unix socket (at most "
                                f"{MAX_PATH_BYTES} bytes)")  # fmt: skip
    folder = path.parent
    try:
        folder_info = os.stat(folder)
    except OSError as error:
        raise CameraServerError(f"{folder}: {error.strerror or error}") from None
    if not stat.S_ISDIR(folder_info.st_mode):
        raise CameraServerError(f"{folder} is not a folder")
    if folder_info.st_mode & stat.S_IWOTH:
        # Anyone could put a socket of their own there for the console to take frames from.
        raise CameraServerError(
            f"{folder} is writable by every user: put the camera's socket in a folder of "
            "your own, such as $XDG_RUNTIME_DIR"
        )
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        pass
    else:
        if not stat.S_ISSOCK(mode):
            raise CameraServerError(f"{path} exists and is not a socket: not replacing it")
        if _answers(path):
            raise CameraServerError(f"{path}: a camera is served there already")
        path.unlink(missing_ok=True)  # stale: its simulator died without removing it
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    # bind creates the file with the umask's mode: private from the start, so that no
    # other user can connect before the chmod. The umask is the process's, so it is put
    # back at once (no other thread of the simulator has started yet).
    previous = os.umask(0o177)
    try:
        listener.bind(str(path))
    except OSError as error:
        listener.close()
        raise CameraServerError(f"cannot listen at {path}: {error.strerror or error}") from None
    finally:
        os.umask(previous)
    os.chmod(path, 0o600)
    listener.listen(MAX_CLIENTS)
    return listener


def _answers(path: Path) -> bool:
    """Whether something accepts connections at the socket file `path`."""
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    probe.settimeout(1.0)  # a listener accepts at once; a stale file refuses at once
    try:
        probe.connect(str(path))
    except (ConnectionRefusedError, FileNotFoundError):
        return False
    except OSError:
        return True  # busy (a full backlog times out): something is there
    finally:
        probe.close()
    return True


def _receive(connection: socket.socket, size: int, deadline: float) -> bytes | None:
    """Exactly `size` bytes by `deadline`; None if the client closed or kept quiet."""
    data = bytearray()
    while len(data) < size:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return None
        connection.settimeout(remaining)
        try:
            chunk = connection.recv(size - len(data))
        except TimeoutError:
            return None
        if not chunk:
            return None
        data += chunk
    return bytes(data)


def _refuse(connection: socket.socket, reason: str) -> None:
    """Say why, without waiting for a client that does not read, and hang up."""
    with contextlib.suppress(OSError):
        connection.setblocking(False)
        connection.send(encode_refusal(reason))
    connection.close()
