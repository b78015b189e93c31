"""The console's camera on a Unix socket (`--camera unix:PATH`): frames as the simulator
draws them, stamped by the console's clock, and None, never an exception or a hang,
when the camera goes away or answers nonsense (camera/source.py SocketCamera)."""

from __future__ import annotations

import math
import shutil
import socket
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from giraff_console.camera import socket_wire
from giraff_console.camera.socket_wire import MAGIC, REPLY, REQUEST, ReplyStatus
from giraff_console.camera.source import (
    OpenCVCamera,
    SocketCamera,
    TestPattern,
    camera_for,
    open_camera,
)
from giraff_console.data_folders import example_floorplan
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim import camera_wire
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.camera_server import CameraServer
from giraff_console.sim.camera_wire import encode_frame_header, encode_refusal
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import demo_world

CAMERA = WorldCamera(demo_world())
POSE = TruePose(0.0, 0.0, 0.0)
# Every wait: long on a loaded two-core machine, short next to a hang.
WAIT_S = 5.0


@pytest.fixture
def socket_path() -> Iterator[Path]:
    """In a private folder with a short path (a socket's has at most 107 bytes)."""
    folder = Path(tempfile.mkdtemp(prefix="cam-", dir="/tmp"))
    yield folder / "camera.sock"
    shutil.rmtree(folder, ignore_errors=True)


def serve(path: Path, camera: WorldCamera = CAMERA) -> CameraServer:
    server = CameraServer(path, camera, lambda: POSE)
    server.start()
    return server


class SlowCamera(WorldCamera):
    """Takes its time over every picture, as a big frame on a busy machine does."""

    def render(self, pose: TruePose, width: int, height: int) -> np.ndarray:
        time.sleep(0.2)
        return super().render(pose, width, height)


def test_the_console_and_the_simulator_speak_the_same_format():
    """Kept alike by hand on both sides of the layers (camera/socket_wire.py)."""
    for name in ("MAGIC", "MIN_SIDE", "MAX_SIDE", "MAX_REASON", "CHANNELS"):
        assert getattr(socket_wire, name) == getattr(camera_wire, name), name
    for name in ("REQUEST", "REPLY"):
        assert getattr(socket_wire, name).format == getattr(camera_wire, name).format, name
    assert {s.name: s.value for s in socket_wire.ReplyStatus} == {
        s.name: s.value for s in camera_wire.ReplyStatus
    }
    request = socket_wire.encode_request(800, 600)
    assert camera_wire.decode_request(request) == (800, 600)
    assert socket_wire.decode_reply(camera_wire.encode_frame_header(800, 600)) == (
        socket_wire.Reply(ReplyStatus.FRAME, 800, 600, 800 * 600 * 3)
    )
    refusal = camera_wire.encode_refusal("é" * 150)  # cut to whole characters
    reply = socket_wire.decode_reply(refusal[: REPLY.size])
    assert reply.status is ReplyStatus.REFUSED and reply.length <= socket_wire.MAX_REASON
    assert refusal[REPLY.size :].decode() == "é" * (socket_wire.MAX_REASON // 2)


def test_the_spec_names_the_camera():
    camera = camera_for("unix:/run/user/1000/camera.sock")
    assert isinstance(camera, SocketCamera) and camera.path == "/run/user/1000/camera.sock"
    assert camera.name == "camera unix:/run/user/1000/camera.sock"
    assert isinstance(camera_for("0"), OpenCVCamera) and camera_for("0").device == 0
    assert camera_for("/dev/video2").device == "/dev/video2"


def test_frames_arrive_exactly_as_the_simulator_draws_them(socket_path):
    server = serve(socket_path)
    camera = SocketCamera(str(socket_path))
    try:
        assert camera.open(640, 480) == (640, 480)
        frame = camera.read()
        assert frame is not None and frame.size == (640, 480)
        assert np.array_equal(frame.image, CAMERA.render(POSE, 640, 480))
    finally:
        camera.close()
        server.close()


def test_a_frame_is_stamped_by_the_console_s_clock_when_it_is_asked_for(socket_path):
    server = serve(socket_path, SlowCamera(demo_world()))
    camera = SocketCamera(str(socket_path))
    try:
        camera.open(64, 48)
        asked = time.monotonic()
        frame = camera.read()
        arrived = time.monotonic()
        assert frame is not None
        # When the simulator took the pose, not 0.2 s later when the picture came.
        assert asked <= frame.captured_at < asked + 0.1
        assert arrived - frame.captured_at >= 0.2
    finally:
        camera.close()
        server.close()
    stamped = SocketCamera(str(socket_path), clock=lambda: 42.0)
    server = serve(socket_path)
    try:
        stamped.open(64, 48)
        frame = stamped.read()
        assert frame is not None and frame.captured_at == 42.0
    finally:
        stamped.close()
        server.close()


def test_a_camera_that_goes_away_reads_none_and_comes_back_with_it(socket_path):
    server = serve(socket_path)
    camera = SocketCamera(str(socket_path))
    try:
        camera.open(64, 48)
        assert camera.read() is not None
        server.close()
        started = time.monotonic()
        assert camera.read() is None
        assert camera.read() is None  # the socket is gone: no connection either
        assert time.monotonic() - started < 1.0
        server = serve(socket_path)  # the simulator started again
        assert camera.read() is not None
    finally:
        camera.close()
        server.close()
    assert camera.read() is None  # closed


def test_a_missing_socket_camera_falls_back_and_says_so(socket_path):
    camera, size, note = open_camera(f"unix:{socket_path}", 640, 480, synthetic=None)
    assert isinstance(camera, TestPattern) and size == (640, 480)
    assert note == f"camera unix:{socket_path} not found; showing the test pattern"


class FakeCamera:
    """A server that answers each request with `reply`, then keeps the connection open
    until the test ends: a broken or a hung camera."""

    def __init__(self, path: Path, reply: bytes) -> None:
        self.reply = reply
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(str(path))
        self.listener.listen(1)
        self.listener.settimeout(WAIT_S)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._answer, daemon=True)
        self.thread.start()

    def _answer(self) -> None:
        try:
            connection, _ = self.listener.accept()
        except OSError:
            return
        with connection:
            connection.settimeout(WAIT_S)
            try:
                connection.recv(REQUEST.size)
                connection.sendall(self.reply)
            except OSError:
                return
            self.done.wait(WAIT_S)

    def close(self) -> None:
        self.done.set()
        self.thread.join(timeout=WAIT_S)
        self.listener.close()


@pytest.mark.parametrize(
    "reply",
    [
        pytest.param(b"", id="says nothing"),
        pytest.param(encode_frame_header(64, 48) + b"\x00" * 100, id="half a frame"),
        pytest.param(b"HTTP/1.1 400 Bad Request\r\n\r\n", id="not the format"),
        pytest.param(REPLY.pack(MAGIC, ReplyStatus.FRAME, 4096, 4096, 2**32 - 1),
                     id="a frame longer than its size"),
        pytest.param(REPLY.pack(MAGIC, ReplyStatus.FRAME, 8, 8, 192), id="too small a frame"),
        pytest.param(encode_frame_header(32, 24) + bytes(32 * 24 * 3), id="another size"),
        pytest.param(REPLY.pack(MAGIC, 7, 64, 48, 0), id="an unknown status"),
        pytest.param(encode_refusal("busy"), id="a refusal"),
        pytest.param(REPLY.pack(MAGIC, ReplyStatus.REFUSED, 0, 0, 10**6), id="a long refusal"),
    ],
)  # fmt: skip
def test_a_camera_that_answers_nonsense_or_nothing_reads_none_in_time(socket_path, reply):
    fake = FakeCamera(socket_path, reply)
    camera = SocketCamera(str(socket_path), timeout=0.3)
    try:
        camera.open(64, 48)
        started = time.monotonic()
        assert camera.read() is None
        assert time.monotonic() - started < 0.3 + 0.5
    finally:
        camera.close()
        fake.close()


def test_the_console_s_camera_feed_finds_the_markers_by_the_calibration(socket_path):
    """`giraff-console --camera unix:PATH --calibration PATH.calibration.yaml`, as the
    simulator's banner says: the markers are placed, so they find the robot."""
    from giraff_console.runtime.camera import camera_feed

    plan = load_floorplan(example_floorplan())
    start = plan.rooms[plan.start]
    server = CameraServer(
        socket_path, WorldCamera(plan_world(plan)),
        lambda: TruePose(*start.at, math.radians(start.heading or 0.0)),
    )  # fmt: skip
    server.start()
    feed = camera_feed(f"unix:{socket_path}", None, str(server.calibration_path),
                       landmarks=plan.landmarks)  # fmt: skip
    try:
        assert isinstance(feed.source, SocketCamera)
        assert feed.note == f"camera unix:{socket_path} at 800x600"
        detector = feed.pipeline.processors["markers"]
        assert detector.intrinsics(800, 600) is not None  # type: ignore[attr-defined]
        feed.set_cells(40, 10)
        picture = feed.picture()
        assert picture is not None and picture.markers == (16,)
    finally:
        feed.stop()
        server.close()
