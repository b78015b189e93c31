"""Which session `p` and a bare `play` pick: the newest, whatever its folder is called."""

from __future__ import annotations

import json
import os
from pathlib import Path

from giraff_console.clock import VirtualClock
from giraff_console.missions.sessions import Sessions
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.teleop import Teleop


def sessions_in(folder: Path) -> Sessions:
    clock = VirtualClock()

    def connect():
        raise AssertionError("choosing a session never touches the board")

    control = ControlLoop(connect, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    return Sessions(control, None, folder, RecordingSetup(port="none"), lambda text: None)


def session(folder: Path, name: str, started: object = None, written: float = 0.0) -> Path:
    """A session folder with a log written at `written`, and a meta.json saying it
    began at `started` (none without)."""
    path = folder / name
    path.mkdir(parents=True)
    log = path / "control.log"
    log.write_text("   0.012:[G] v: 0.60000\n")
    os.utime(log, (written, written))
    if started is not None:
        (path / "meta.json").write_text(json.dumps({"format": 1, "started_unix": started}))
    return path


def test_the_newest_session_is_the_one_that_began_last_not_the_last_by_name(tmp_path):
    session(tmp_path, "sample", started=1_700_000_000.0)
    newest = session(tmp_path, "20261123_100000", started=1_800_000_000.0)
    session(tmp_path, "20261122_090000", started=1_790_000_000.0)
    assert sessions_in(tmp_path).latest() == newest


def test_a_sample_that_is_the_newest_in_the_folder_is_played(tmp_path):
    session(tmp_path, "20240501_100000", started=1_714_550_400.0)
    sample = session(tmp_path, "sample", started=1_795_332_332.6)
    assert sessions_in(tmp_path).latest() == sample


def test_a_log_without_meta_counts_from_when_it_was_last_written(tmp_path):
    # An original console's log: no meta.json.
    session(tmp_path, "old", started=1_000.0)
    newest = session(tmp_path, "original", written=2_000.0)
    assert sessions_in(tmp_path).latest() == newest


def test_an_unreadable_start_time_counts_from_when_the_log_was_last_written(tmp_path):
    broken = session(tmp_path, "broken", written=5_000.0)
    (broken / "meta.json").write_text("{not json")
    session(tmp_path, "nan", started=float("nan"), written=4_000.0)
    session(tmp_path, "true", started=True, written=3_000.0)
    session(tmp_path, "huge", started=10**400, written=2_000.0)
    assert sessions_in(tmp_path).latest() == broken


def test_folders_without_a_log_and_a_missing_folder_give_nothing_to_play(tmp_path):
    (tmp_path / "empty").mkdir()
    assert sessions_in(tmp_path).latest() is None
    assert sessions_in(tmp_path / "missing").latest() is None
