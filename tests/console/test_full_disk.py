"""A disk that fills up stops the recording, says so, and leaves driving alone.

The console runs in tmux with a file size limit (`ulimit -f`): every write past it
fails with EFBIG, exactly as writes to a full disk fail with ENOSPC.
"""

from __future__ import annotations

import contextlib
import re
import shlex
import shutil
import tempfile
import time
from pathlib import Path

import pytest

from tests.console.support import SimulatedRobot, Tmux, console_command, pose_at

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

# Kilobytes per file: about two seconds of the control log.
LIMIT_KB = 8


def status_text(screen: str) -> str:
    """The status pane's words run together, so that a wrapped message can be found."""
    pane = [line.split("│")[1] for line in screen.splitlines() if line.count("│") >= 2]
    return re.sub(r"\s+", "", "".join(pane))


def test_a_full_disk_stops_the_recording_and_driving_goes_on(tmp_path):
    robot = SimulatedRobot(tmp_path)
    # A short folder: the status pane is 18 columns wide, and the message that the
    # recording stopped names its file; under a long path (pytest-xdist's) its first
    # words scroll out of the pane before they can be read.
    short = Path(tempfile.mkdtemp(prefix="fd-", dir="/tmp"))
    recordings = short / "rec"
    console = shlex.join(console_command(robot.path, "--recordings", str(recordings)))
    # Each is ended on every way out, so that no console is left holding the board's pty.
    with contextlib.ExitStack() as cleanup:
        cleanup.callback(shutil.rmtree, short, ignore_errors=True)
        cleanup.callback(robot.close)
        tmux = Tmux(["sh", "-c", shlex.quote(f"ulimit -f {LIMIT_KB}; exec {console}")])
        cleanup.callback(tmux.kill)
        tmux.wait_for("connected to")
        tmux.keys("r")
        tmux.wait_for("REC")
        deadline = time.monotonic() + 20
        while "recordingstopped" not in status_text(tmux.screen()):
            assert time.monotonic() < deadline, tmux.screen()
            tmux.hold("Up", 1.0)
            time.sleep(0.5)
        assert "REC" not in tmux.screen().splitlines()[0]
        assert "Filetoolarge" in status_text(tmux.screen())
        # Driving is as it was: a 2 s hold still covers most of a metre.
        start = time.monotonic()
        tmux.hold("Up", 2.0)
        time.sleep(1.5)
        samples = robot.samples()
        assert pose_at(samples, time.monotonic()).x - pose_at(samples, start).x > 0.5
        assert "LINK LOST" not in tmux.screen()
        (session,) = recordings.iterdir()
        assert (session / "control.log").stat().st_size <= LIMIT_KB * 1024
