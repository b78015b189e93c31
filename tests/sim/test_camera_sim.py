"""`giraff-console sim --pty --floorplan PLAN --camera SOCKET` in another process: the
console reads its camera as it reads a real one, and finds the plan's markers in it by
the calibration the simulator hands over, never by the simulator's pose (issue 25)."""

from __future__ import annotations

import math
import os
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import pytest

from giraff_console.camera.markers import MarkerSighting
from giraff_console.camera.processors import Undistortion
from giraff_console.camera.socket_wire import MAGIC, REQUEST, encode_request
from giraff_console.camera.source import Frame, SocketCamera
from giraff_console.data_folders import example_floorplan
from giraff_console.link import BoardLink
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.landmarks import marker_detector
from tests.conftest import CHILD_TIMEOUT, kill_process, start_sim_process, stop_sim_process
from tests.sim.test_camera_server import refusal

pytestmark = pytest.mark.pty

PLAN_PATH = example_floorplan()
PLAN = load_floorplan(PLAN_PATH)
MARKERS = {marker.id: marker for marker in PLAN.landmarks.markers}
START = PLAN.rooms[PLAN.start]
# Every wait: long on a loaded two-core machine, short next to a hang.
WAIT_S = 5.0


class CameraSim:
    """The simulator in another process with its camera, and the console's view of it."""

    def __init__(self, folder: Path, *extra: str) -> None:
        self.socket = folder / "camera.sock"
        self.process, self.pty = start_sim_process(
            "--floorplan", str(PLAN_PATH), "--camera", str(self.socket), *extra
        )
        self.calibration = folder / "camera.sock.calibration.yaml"
        self.undistortion = Undistortion.from_file(str(self.calibration))
        # The console's own detector, knowing the camera only by its calibration.
        self.detector = marker_detector(PLAN.landmarks, self.undistortion.intrinsics)
        self.camera = SocketCamera(str(self.socket))
        assert self.camera.open(800, 600) == (800, 600)

    def look(self) -> tuple[Frame, list[MarkerSighting]]:
        frame = self.camera.read()
        assert frame is not None, "no frame from the simulator's camera"
        grey = cv2.cvtColor(self.undistortion.apply(frame.image), cv2.COLOR_BGR2GRAY)
        return frame, self.detector.detect(grey, frame.captured_at)

    def stop(self) -> int:
        self.camera.close()
        return stop_sim_process(self.process)


@pytest.fixture
def folder() -> Iterator[Path]:
    """A private folder with a short path (a socket's has at most 107 bytes)."""
    path = Path(tempfile.mkdtemp(prefix="cam-", dir="/tmp"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope="module")
def camera_sim() -> Iterator[CameraSim]:
    """One simulator for the tests that leave the robot where the plan starts it."""
    folder = Path(tempfile.mkdtemp(prefix="cam-", dir="/tmp"))
    sim = CameraSim(folder)
    try:
        yield sim
    finally:
        try:
            assert sim.stop() == 0
        finally:
            shutil.rmtree(folder, ignore_errors=True)


def assert_seen_from(sightings: list[MarkerSighting], x: float, y: float, heading: float) -> None:
    """Every sighting is of a marker of the plan, at the distance and bearing that the
    plan's map puts it from the pose (x, y, heading)."""
    assert sightings, "no marker found"
    for sighting in sightings:
        marker = MARKERS[sighting.id]
        dx, dy = marker.at[0] - x, marker.at[1] - y
        bearing = math.remainder(math.atan2(dy, dx) - heading, math.tau)
        assert sighting.distance_m == pytest.approx(math.hypot(dx, dy), abs=0.02)
        assert sighting.bearing_rad == pytest.approx(bearing, abs=math.radians(0.3))


def test_the_camera_s_socket_is_private_and_gone_when_the_simulator_ends(folder):
    sim = CameraSim(folder)
    mode = os.lstat(sim.socket).st_mode
    assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600
    assert sim.stop() == 0
    assert sim.process.stderr is not None
    banner = sim.process.stderr.read()
    assert f"camera on {sim.socket}" in banner and str(sim.calibration) in banner
    assert f"--camera unix:{sim.socket} --calibration {sim.calibration}" in banner
    assert list(folder.iterdir()) == []


def test_the_console_finds_the_plan_s_markers_where_the_plan_hangs_them(camera_sim):
    before = time.monotonic()
    frame, sightings = camera_sim.look()
    assert frame.image.shape == (600, 800, 3)
    # Stamped by the console's clock, when it asked.
    assert before <= frame.captured_at <= time.monotonic()
    assert_seen_from(sightings, *START.at, math.radians(START.heading or 0.0))


def test_driving_the_board_on_the_pty_changes_what_the_camera_sees(folder):
    pose_log = folder / "pose.log"
    sim = CameraSim(folder, "--pose-log", str(pose_log))
    try:
        _, at_start = sim.look()
        link = BoardLink.open(sim.pty)
        try:
            # A quarter turn to the right on the spot, then half a metre ahead (A.4.2).
            for name, value in (("r", 0), ("a", 1.0), ("v", 0.5), ("p", 90)):
                link.set(name, value)
            wait_until_stopped(link)
            link.set("r", 1)
            link.set("p", 0.5)
            wait_until_stopped(link)
        finally:
            link.close()
        _, after = sim.look()
        # Only the test reads the true pose, from the simulator's log of it.
        x, y, heading_deg = last_pose(pose_log)
        assert math.hypot(x - START.at[0], y - START.at[1]) == pytest.approx(0.5, abs=0.01)
        assert {s.id for s in after} != {s.id for s in at_start}
        assert_seen_from(after, x, y, math.radians(heading_deg))
    finally:
        assert sim.stop() == 0


def test_a_client_that_never_reads_does_not_stop_the_board_answering(camera_sim):
    stuck = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stuck.settimeout(WAIT_S)
    stuck.connect(str(camera_sim.socket))
    # Frames of 1600x1200 (5.8 MB each), never read.
    stuck.sendall(encode_request(1600, 1200) * 4)
    link = BoardLink.open(camera_sim.pty)
    try:
        started = time.monotonic()
        while time.monotonic() - started < 3.0:  # past the server's send timeout
            asked = time.monotonic()
            link.get("v")
            assert time.monotonic() - asked < 0.5, "the board was held up"
            time.sleep(0.02)
        _, sightings = camera_sim.look()  # and the camera serves others all along
        assert sightings
    finally:
        link.close()
        stuck.close()


@pytest.mark.parametrize(
    ("request_bytes", "why"),
    [
        (b"\x00" * REQUEST.size, "not a frame request"),
        (REQUEST.pack(MAGIC, 4097, 600), "4097x600"),
        (REQUEST.pack(MAGIC, 800, 8), "800x8"),
    ],
)
def test_a_bad_request_is_refused(camera_sim, request_bytes, why):
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
        client.settimeout(WAIT_S)
        client.connect(str(camera_sim.socket))
        client.sendall(request_bytes)
        assert why in refusal(client)


@pytest.mark.parametrize(
    ("arguments", "complaint"),
    [
        (["--camera", "{folder}/camera.sock"], "--camera needs --floorplan"),
        (["--floorplan", str(PLAN_PATH), "--camera", "{folder}/notes.txt"], "not a socket"),
        (["--floorplan", str(PLAN_PATH), "--camera", "/tmp/camera.sock"],
         "writable by every user"),
    ],
)  # fmt: skip
def test_the_simulator_will_not_serve_its_camera_where_it_is_unsafe(folder, arguments, complaint):
    (folder / "notes.txt").write_text("kept")
    command = [a.format(folder=folder) for a in arguments]
    process = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", *command],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        out, err = process.communicate(timeout=CHILD_TIMEOUT)
    except subprocess.TimeoutExpired:
        kill_process(process)
        raise
    assert process.returncode == 2 and complaint in err and out == ""
    assert (folder / "notes.txt").read_text() == "kept"


def test_a_simulator_that_dies_leaves_a_socket_the_next_one_replaces(folder):
    first = CameraSim(folder)
    first.camera.close()
    first.process.send_signal(signal.SIGKILL)
    first.process.wait(timeout=CHILD_TIMEOUT)
    assert first.socket.exists()  # nobody removed it
    orphan = SocketCamera(str(first.socket))
    orphan.open(800, 600)
    assert orphan.read() is None
    second = CameraSim(folder)
    try:
        _, sightings = second.look()
        assert sightings
    finally:
        assert second.stop() == 0


def wait_until_stopped(link: BoardLink) -> None:
    deadline = time.monotonic() + 10.0
    while link.bulk().moving:
        assert time.monotonic() < deadline, "the move did not end"
        time.sleep(0.02)


def last_pose(path: Path) -> tuple[float, float, float]:
    """The pose log's latest (x, y, heading in degrees), once it has caught up."""
    time.sleep(0.1)  # two of the log's periods
    _, x, y, heading, _ = path.read_text().strip().splitlines()[-1].split()
    return float(x), float(y), float(heading)
