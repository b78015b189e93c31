"""A second local user can read nothing the robot wrote, with the recordings folder set
anywhere (issue 30).

The robot records a session on the simulator (its control log, meta.json, estimates and
camera video written by OpenCV), teaches and saves a route, logs a patrol run, keeps its
pose and prints marker pages, all into a fresh 0755 folder of the operator's outside
the test's own (private) temporary folder; the real command line then exports the
session and makes a floor plan from a scan there. The writers run under a umask of
0o022, the loosest a caller might have, so that the modes are theirs and not the
program's umask; the commands run through the program's entry point, whose own umask
(0o077) covers writers that give no mode.

As root, a child that has become nobody (uid and gid 65534) then tries to list every
folder and open every file written: each attempt must fail with PermissionError, and
the operator's own folder, which keeps its 0755, must still be listable (or the
attempts would fail for the wrong reason). As anyone else, only the modes are checked.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from giraff_console import launch
from giraff_console.camera.source import Frame
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol_log import PatrolRunLog
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.marker_pages import write_pages
from giraff_console.planning.route_planner import walls_of
from giraff_console.private_files import PRIVATE_UMASK
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.pose_keeper import PoseKeeper
from tests.buildings.scanned_home import home_image
from tests.missions.site import PLAN, Site
from tests.planning.scanned_rooms import write_scanned_map

NOBODY = 65534
# What a second user tries on each thing written, in a child that has become nobody:
# the paths it could read, as JSON. Folders are listed, files opened for reading.
SECOND_USER = """
import json, os, sys
read = []
for path in json.loads(sys.stdin.read()):
    try:
        if os.path.isdir(path):
            os.listdir(path)
        else:
            os.close(os.open(path, os.O_RDONLY | os.O_NONBLOCK))
    except PermissionError:
        continue
    read.append(path)
print(json.dumps(read))
"""


@pytest.fixture
def operators_folder() -> Iterator[Path]:
    """A fresh folder the operator made, 0755, where a second user can reach it: not in
    pytest's own temporary folder, which is 0700 and would refuse nobody for us."""
    folder = Path(tempfile.mkdtemp(prefix="giraff-private-", dir="/tmp"))
    folder.chmod(0o755)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def loose_umask() -> Iterator[None]:
    """The loosest umask a caller of the package may have: the writers give the modes."""
    previous = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(previous)


def record_teach_and_log(folder: Path) -> Path:
    """Everything the robot writes: sessions into `folder`, the recordings folder, and
    the rest into folders made in it (routes/, patrol-runs/, ...); the session recorded."""
    navigator = Navigator(PLAN, walls_of(PLAN))
    site = Site(navigator)
    said: list[str] = []
    # The recordings folder is the operator's own, 0755.
    sessions = Sessions(site.control, None, folder,
                        RecordingSetup(port="giraff-sim://"), said.append)  # fmt: skip
    drives = DriveSetup.on_loop(site.control, navigator, sense=site.sense)
    book = RouteBook(site.control, sessions, folder / "routes", said.append, drives)
    site.run(0.3, until_ended=False)  # the link up, the board's settings known
    assert book.teach("round"), said
    session = sessions.recorder.path if sessions.recorder else None
    assert session is not None, said
    # A second of camera video, written by OpenCV as the console writes it.
    rng = np.random.default_rng(30)
    for index in range(12):
        image = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
        sessions.recorder.frame(Frame(image, site.control.clock.now() + index * 0.1))
    site.run(0.5, until_ended=False)
    book.mark("here")
    route = book.done()
    assert route is not None and route.exists(), said
    patrols = PatrolRunLog(folder / "patrol-runs")
    assert patrols.start("night", scheduled=False, by="a test") is None
    assert patrols.end("done", True, 1) is None
    keeper = PoseKeeper(folder / "state" / "pose.json", PLAN.path)
    site.control.subscribe(keeper.hear)
    site.run(0.3, until_ended=False)
    keeper.close()
    write_pages(load_floorplan(PLAN.path), folder / "markers")
    return session


def written(folder: Path) -> list[Path]:
    """Every file and folder under `folder`, not `folder` itself."""
    return sorted(path for path in folder.rglob("*"))


def test_nothing_the_robot_writes_can_be_read_by_a_second_user(
    operators_folder, loose_umask, tmp_path
):
    session = record_teach_and_log(operators_folder)
    assert (session / "camera").is_dir() and any((session / "camera").iterdir())
    # Straight into the operator's 0755 folder: the file's own mode must keep it.
    export = operators_folder / "session.mcap"
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "export", str(session), str(export)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    # A floor plan made from a scan by the command line: its plan, grid and picture are
    # written by writers that give no mode (plan_writing.py, OpenCV): the program's
    # umask covers them. The scan itself is the test's, in its own private folder.
    scan = write_scanned_map(tmp_path, "home-map", home_image())
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "floorplan", "rooms", str(scan),
         str(operators_folder / "home.yaml")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    paths = written(operators_folder)
    names = {path.name for path in paths}
    assert {"control.log", "meta.json", "round.yaml", "pose.json", "markers.pdf",
            "session.mcap", "home.yaml", "home-rooms.png"} <= names  # fmt: skip
    assert any(path.suffix == ".mp4" for path in paths)
    # The operator's folder keeps the mode they gave it; all in it is theirs alone.
    assert stat.S_IMODE(operators_folder.stat().st_mode) == 0o755
    loose = [f"{path} {stat.S_IMODE(path.stat().st_mode):o}" for path in paths
             if path.stat().st_mode & 0o077]  # fmt: skip
    assert loose == []
    if os.geteuid() != 0:
        pytest.skip("not root: cannot become a second user here (the modes are checked)")
    # The system's Python: the test's own may live where nobody may go (root's home).
    python = next((p for p in ("/usr/bin/python3", "/usr/local/bin/python3")
                   if os.access(p, os.X_OK)), None)  # fmt: skip
    if python is None:
        pytest.skip("no system Python for the second user to run (the modes are checked)")
    asked = [str(path) for path in [operators_folder, *paths]]
    child = subprocess.run(
        [python, "-I", "-c", SECOND_USER], input=json.dumps(asked), capture_output=True,
        text=True, timeout=60, user=NOBODY, group=NOBODY, extra_groups=[], cwd="/",
        env={"PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert child.returncode == 0, child.stderr
    # The operator's own folder is open to all: the second user got that far.
    assert json.loads(child.stdout) == [str(operators_folder)]


def test_the_program_starts_with_the_private_umask() -> None:
    # launch.py sets it without loading private_files (the operator's stop's start-up).
    assert launch.UMASK == PRIVATE_UMASK
