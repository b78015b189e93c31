"""The synthetic camera's socket server, in-process: who may connect, what it refuses,
and that no client can hold it up (sim/camera_server.py)."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import stat
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from giraff_console.camera.processors import Undistortion
from giraff_console.camera.socket_wire import (
    MAGIC,
    REPLY,
    REQUEST,
    ReplyStatus,
    decode_reply,
    encode_request,
)
from giraff_console.sim import camera_server
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.camera_server import MAX_CLIENTS, CameraServer, CameraServerError
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import demo_world

# Every wait in these tests: long on a loaded two-core machine, short next to a hang.
WAIT_S = 5.0
CAMERA = WorldCamera(demo_world())
POSE = TruePose(0.0, 0.0, 0.0)


@pytest.fixture
def folder() -> Iterator[Path]:
    """A private folder with a short path: a Unix socket's path has at most 107 bytes,
    which pytest's own temporary folders can exceed."""
    path = Path(tempfile.mkdtemp(prefix="cam-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


@pytest.fixture
def server(folder: Path) -> Iterator[CameraServer]:
    served = CameraServer(folder / "camera.sock", CAMERA, lambda: POSE)
    served.start()
    yield served
    served.close()


def connect(path: Path) -> socket.socket:
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.settimeout(WAIT_S)
    client.connect(str(path))
    return client


def receive(client: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = client.recv(size - len(data))
        assert chunk, f"the server closed after {len(data)} of {size} bytes"
        data += chunk
    return data


def refusal(client: socket.socket) -> str:
    """The reason of a refusal, and checks that the server then hangs up."""
    reply = decode_reply(receive(client, REPLY.size))
    assert reply.status is ReplyStatus.REFUSED
    reason = receive(client, reply.length).decode()
    assert client.recv(1) == b""
    return reason


def frame(client: socket.socket, width: int, height: int) -> np.ndarray:
    client.sendall(encode_request(width, height))
    reply = decode_reply(receive(client, REPLY.size))
    assert (reply.status, reply.width, reply.height) == (ReplyStatus.FRAME, width, height)
    return np.frombuffer(receive(client, reply.length), np.uint8).reshape(height, width, 3)


def test_the_socket_is_the_user_s_alone_and_goes_with_the_server(folder):
    served = CameraServer(folder / "camera.sock", CAMERA, lambda: POSE)
    mode = os.lstat(served.path).st_mode
    assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600
    assert served.calibration_path == folder / "camera.sock.calibration.yaml"
    assert served.calibration_path.is_file()
    served.start()
    served.close()
    assert list(folder.iterdir()) == []


def test_the_calibration_beside_it_is_the_camera_s_pinhole(server):
    """The console's undistortion with it leaves the picture as drawn, and its intrinsics
    are the camera's, at the calibrated size and at the console's other 4:3 sizes."""
    undistortion = Undistortion.from_file(str(server.calibration_path))
    image = CAMERA.render(POSE, 800, 600)
    assert np.abs(undistortion.apply(image).astype(int) - image).max() <= 1
    for width, height in ((800, 600), (640, 480), (1600, 1200)):
        known, read = CAMERA.intrinsics(width, height), undistortion.intrinsics(width, height)
        assert read.fx == pytest.approx(known.fx) and read.fy == pytest.approx(known.fy)
        # Scaling a calibration moves the principal point by under half a pixel.
        assert read.cx == pytest.approx(known.cx, abs=0.5)
        assert read.cy == pytest.approx(known.cy, abs=0.5)


def test_a_frame_is_the_picture_drawn_from_the_pose_when_asked(server):
    with connect(server.path) as client:
        assert np.array_equal(frame(client, 320, 240), CAMERA.render(POSE, 320, 240))
        # One connection, frame after frame, of any size within bounds.
        assert frame(client, 16, 4096).shape == (4096, 16, 3)


@pytest.mark.parametrize(
    ("request_bytes", "why"),
    [
        (b"GET / HT", "not a frame request"),
        (REQUEST.pack(MAGIC, 15, 600), "15x600"),
        (REQUEST.pack(MAGIC, 800, 4097), "800x4097"),
        (REQUEST.pack(MAGIC, 0, 0), "0x0"),
    ],
)  # fmt: skip
def test_a_bad_request_is_refused_with_why_and_the_connection_closed(server, request_bytes, why):
    with connect(server.path) as client:
        client.sendall(request_bytes)
        reason = refusal(client)
    assert why in reason
    with connect(server.path) as client:  # the server carries on for others
        assert frame(client, 64, 48).shape == (48, 64, 3)


def test_a_client_that_stops_reading_holds_up_no_other_and_is_dropped(server):
    stuck = connect(server.path)
    # Asks for frames far bigger than the socket's buffers, and reads none of them.
    stuck.sendall(encode_request(1024, 768) * 3)
    try:
        time.sleep(0.2)  # drawn, and being sent
        with connect(server.path) as client:
            started = time.monotonic()
            assert frame(client, 320, 240).shape == (240, 320, 3)
            # Not after the stuck one's SEND_TIMEOUT_S.
            assert time.monotonic() - started < camera_server.SEND_TIMEOUT_S / 2
        time.sleep(camera_server.SEND_TIMEOUT_S)
        # Dropped: what the socket's buffers held of the first frame, then the end (a
        # reset, since the server hung up on the requests it had not read).
        received = 0
        with contextlib.suppress(ConnectionResetError):
            while chunk := stuck.recv(1 << 16):
                received += len(chunk)
        assert 0 < received < REPLY.size + 1024 * 768 * 3
    finally:
        stuck.close()


def test_a_client_that_says_nothing_is_dropped(server, monkeypatch):
    monkeypatch.setattr(camera_server, "IDLE_S", 0.3)
    with connect(server.path) as client:
        client.sendall(encode_request(64, 48)[:3])  # and never the rest
        assert client.recv(1) == b""  # hung up on, within WAIT_S


def test_only_a_few_clients_are_served_at_once(server):
    clients = [connect(server.path) for _ in range(MAX_CLIENTS)]
    try:
        for client in clients:  # each one has its thread by now
            assert frame(client, 32, 24).shape == (24, 32, 3)
        with connect(server.path) as extra:
            assert "busy" in refusal(extra)
    finally:
        for client in clients:
            client.close()
    # The places come free as the server notices the clients gone, within moments.
    deadline = time.monotonic() + WAIT_S
    while True:
        with connect(server.path) as client:
            try:
                client.sendall(encode_request(32, 24))
                reply = decode_reply(receive(client, REPLY.size))
            except (BrokenPipeError, ConnectionResetError):
                # Refused and closed before the request was written: still busy.
                reply = None
            if reply is not None and reply.status is ReplyStatus.FRAME:
                break
        assert time.monotonic() < deadline, "the clients that left still hold their places"
        time.sleep(0.05)


def test_closing_hangs_up_on_clients_at_once(folder):
    served = CameraServer(folder / "camera.sock", CAMERA, lambda: POSE)
    served.start()
    client = connect(served.path)
    frame(client, 32, 24)
    started = time.monotonic()
    served.close()
    assert time.monotonic() - started < 1.0
    assert client.recv(1) == b""
    client.close()


def test_the_pose_is_read_when_the_frame_is_asked_for(folder):
    asked = threading.Event()
    poses = iter([TruePose(0.0, 0.0, 0.0), TruePose(0.0, 0.0, 1.5)])

    def pose() -> TruePose:
        asked.set()
        return next(poses)

    served = CameraServer(folder / "camera.sock", CAMERA, pose)
    served.start()
    try:
        with connect(served.path) as client:
            time.sleep(0.05)
            assert not asked.is_set()  # not on connecting: on asking
            first, turned = frame(client, 64, 48), frame(client, 64, 48)
        assert np.array_equal(first, CAMERA.render(TruePose(0.0, 0.0, 0.0), 64, 48))
        assert np.array_equal(turned, CAMERA.render(TruePose(0.0, 0.0, 1.5), 64, 48))
    finally:
        served.close()


def test_an_existing_file_is_never_replaced(folder):
    path = folder / "camera.sock"
    path.write_text("precious")
    with pytest.raises(CameraServerError, match="not a socket"):
        CameraServer(path, CAMERA, lambda: POSE)
    assert path.read_text() == "precious"


def test_a_folder_every_user_may_write_to_is_refused(folder):
    os.chmod(folder, 0o777)
    with pytest.raises(CameraServerError, match="writable by every user"):
        CameraServer(folder / "camera.sock", CAMERA, lambda: POSE)
    assert list(folder.iterdir()) == []


def test_a_path_too_long_for_a_socket_is_refused(folder):
    with pytest.raises(CameraServerError, match="too long"):
        CameraServer(folder / ("c" * 120), CAMERA, lambda: POSE)


def test_a_socket_in_use_is_left_alone_and_a_stale_one_replaced(server):
    with pytest.raises(CameraServerError, match="served there already"):
        CameraServer(server.path, CAMERA, lambda: POSE)
    stale = server.path.with_name("stale.sock")
    left = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    left.bind(str(stale))
    left.close()  # the file stays, with nothing behind it: a simulator that was killed
    replacing = CameraServer(stale, CAMERA, lambda: POSE)
    replacing.start()
    try:
        with connect(stale) as client:
            assert frame(client, 32, 24).shape == (24, 32, 3)
    finally:
        replacing.close()
    assert not stale.exists()


def test_the_simulator_s_camera_shows_the_plan_s_closed_doors():
    """`sim --camera` draws the building as the console's own simulator does: a door the
    plan says is closed fills its doorway (runtime/camera.py plan_camera)."""
    from giraff_console.planning.floorplan import load_floorplan
    from giraff_console.runtime.camera import plan_camera

    plan = load_floorplan(Path(__file__).parent.parent / "planning/fixtures/small-home.yaml")
    camera = plan_camera(plan)
    assert camera.surroundings is not None
    assert list(camera.surroundings.doors) == ["kitchen-lounge"]
    # From the lounge, a metre from the kitchen door, looking at it.
    facing_the_door = TruePose(9.0, 5.0, 0.0)
    shut = camera.render(facing_the_door, 160, 120)
    opened = WorldCamera(camera.world).render(facing_the_door, 160, 120)
    assert not np.array_equal(shut[60, 70:90], opened[60, 70:90])
