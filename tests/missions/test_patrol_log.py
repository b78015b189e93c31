"""The log of patrol runs: written a line at a time, read back whatever state it is in."""

from __future__ import annotations

import datetime as dt
import json
import math
import os

import pytest

from giraff_console.missions.patrol_log import UNFINISHED, PatrolRunLog, list_runs

CET = dt.timezone(dt.timedelta(hours=1))


class Ticking:
    """A wall clock that moves a minute each time it is read."""

    def __init__(self, start: dt.datetime) -> None:
        self.when = start

    def __call__(self) -> dt.datetime:
        now = self.when
        self.when += dt.timedelta(minutes=1)
        return now


def night_clock(hour: int = 22) -> Ticking:
    return Ticking(dt.datetime(2025, 1, 1, hour, 0, tzinfo=CET))


def lines(path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def log_a_run(folder, hour: int = 22, *, finish: bool = True) -> PatrolRunLog:
    log = PatrolRunLog(folder, now=night_clock(hour))
    log.start("night", scheduled=True, by="schedule")
    log.stop({"stop": 1, "round": 1, "room": "lounge", "arrived": True, "why": "done"})
    log.snapshot(folder / "lounge.png")
    log.stop({"stop": 2, "round": 1, "room": "kitchen", "arrived": True, "why": "done"})
    if finish:
        log.end("done", arrived=True, stops=2)
    return log


def test_a_run_is_written_a_line_per_event(tmp_path):
    log = log_a_run(tmp_path)
    assert log.problem is None
    assert log.path is not None and log.path.name == "20250101T210000Z-night.jsonl"
    start, stop, snapshot, _, end = lines(log.path)
    assert start == {"event": "start", "patrol": "night", "at": "2025-01-01T22:00:00+01:00",
                     "scheduled": True, "by": "schedule"}  # fmt: skip
    assert (stop["event"], stop["room"], stop["at"]) == (
        "stop",
        "lounge",
        "2025-01-01T22:01:00+01:00",
    )
    assert snapshot["path"] == str(tmp_path / "lounge.png")
    assert end == {"event": "end", "at": "2025-01-01T22:04:00+01:00", "why": "done",
                   "arrived": True, "stops": 2}  # fmt: skip


def test_a_run_is_read_back_as_a_summary(tmp_path):
    log = log_a_run(tmp_path)
    [run] = list_runs(tmp_path)
    assert run.to_json() == {
        "patrol": "night", "started": "2025-01-01T22:00:00+01:00",
        "ended": "2025-01-01T22:04:00+01:00", "why": "done", "scheduled": True,
        "by": "schedule", "stops": 2, "arrived": True, "snapshots": 1,
        "file": str(log.path), "state": "ended", "notes": [],
    }  # fmt: skip


def test_runs_are_listed_newest_first_up_to_the_limit(tmp_path):
    for hour in (20, 22, 18):
        log_a_run(tmp_path, hour)
    assert [run.started[11:16] for run in list_runs(tmp_path)] == ["22:00", "20:00", "18:00"]
    assert [run.started[11:16] for run in list_runs(tmp_path, limit=2)] == ["22:00", "20:00"]
    assert list_runs(tmp_path / "none yet") == []


def test_a_stop_record_that_is_not_plain_json_is_still_written(tmp_path):
    log = PatrolRunLog(tmp_path, now=night_clock())
    log.start("night", scheduled=False, by="console pts/3")
    # A stop without a goal has no pose error: NaN in Python, null in the log.
    log.stop({"event": "not mine", "error_m": math.nan, "pose": (1.0, math.inf), "seen": []})
    stop = lines(log.path)[1]
    assert stop["event"] == "stop"
    assert (stop["error_m"], stop["pose"]) == (None, [1.0, None])


def test_a_run_is_listed_in_words(tmp_path):
    log_a_run(tmp_path, hour=20)
    failed = PatrolRunLog(tmp_path, now=night_clock(22))
    failed.start("night", scheduled=False, by="console")
    failed.stop({"stop": 1, "round": 1, "room": "lounge", "arrived": False, "why": "stalled"})
    failed.end("done", arrived=False, stops=1)
    log_a_run(tmp_path, hour=23, finish=False)
    lines_ = [run.line() for run in list_runs(tmp_path)]
    assert lines_ == [
        f"2025-01-01T23:00:00+01:00  night  by schedule: unfinished, 2 stops; {UNFINISHED}",
        "2025-01-01T22:00:00+01:00  night  by console: ended, 1 stop, not every stop reached; done",
        "2025-01-01T20:00:00+01:00  night  by schedule: ended, 2 stops, every stop reached; done",
    ]
    assert not any("True" in line or "False" in line for line in lines_)


def test_a_killed_run_reads_as_unfinished_unless_it_is_the_one_running(tmp_path):
    log = log_a_run(tmp_path, finish=False)
    # Every line is out already: the daemon could be killed here.
    [run] = list_runs(tmp_path)
    assert (run.state, run.ended, run.why, run.stops, run.arrived) == (
        "unfinished", None, UNFINISHED, 2, None,
    )  # fmt: skip
    [run] = list_runs(tmp_path, running=log.path)
    assert (run.state, run.why) == ("running", "running")


def test_a_truncated_last_line_is_skipped_with_a_note(tmp_path):
    log = log_a_run(tmp_path)
    assert log.path is not None
    text = log.path.read_bytes()
    log.path.write_bytes(text[: len(text) - 20])  # killed mid-write: half an end line
    [run] = list_runs(tmp_path)
    assert run.state == "unfinished" and run.stops == 2
    assert run.notes == ("line 5 could not be read and was skipped",)


def test_garbled_lines_are_noted_never_raised(tmp_path):
    (tmp_path / "20250101T210000Z-night.jsonl").write_bytes(
        b'\xff\xfe\n[1, 2]\n{"event": 3}\n' + b"[" * 100_000 + b"\n"
    )
    [run] = list_runs(tmp_path)
    assert (run.patrol, run.started, run.state) == ("night", None, "unfinished")
    assert len(run.notes) == 4


def test_a_skipped_slot_has_a_run_file_of_its_own(tmp_path):
    log = PatrolRunLog(tmp_path, now=night_clock())
    assert log.skipped("night", "the previous run of night has not finished") is None
    [run] = list_runs(tmp_path)
    assert (run.state, run.why, run.scheduled, run.stops) == (
        "skipped", "the previous run of night has not finished", True, 0,
    )  # fmt: skip
    assert run.started == run.ended == "2025-01-01T22:00:00+01:00"


def test_two_runs_in_the_same_second_get_two_files(tmp_path):
    frozen = dt.datetime(2025, 1, 1, 22, 0, tzinfo=CET)
    PatrolRunLog(tmp_path, now=lambda: frozen).skipped("night", "busy")
    log_a_run(tmp_path)
    assert len(list_runs(tmp_path)) == 2


def test_a_full_disk_is_reported_not_raised(tmp_path):
    # /dev/full takes the file's place: every write fails with ENOSPC, as on a full disk.
    log = PatrolRunLog(
        tmp_path, now=night_clock(), opener=lambda path: os.open("/dev/full", os.O_WRONLY)
    )
    problem = log.start("night", scheduled=True, by="schedule")
    assert problem is not None and "No space left on device" in problem
    assert log.stop({"stop": 1}) is not None
    assert log.snapshot("x.png") is not None
    log.end("done", arrived=True, stops=1)
    assert log.problem == problem  # the first failure is the one kept


def test_a_write_that_fails_part_way_costs_only_its_own_line(tmp_path):
    log = PatrolRunLog(tmp_path, now=night_clock())
    log.start("night", scheduled=True, by="schedule")
    assert log.path is not None
    real = log._fd
    full = os.open("/dev/full", os.O_WRONLY)
    log._fd = full
    assert log.stop({"stop": 1}) is not None
    log._fd = real
    os.close(full)
    assert log.end("stopped", arrived=False, stops=1) is None
    [run] = list_runs(tmp_path)
    assert (run.state, run.why, run.stops) == ("ended", "stopped", 1)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_folder_that_cannot_be_written_is_reported_not_raised(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        log = PatrolRunLog(folder, now=night_clock())
        assert log.start("night", scheduled=True, by="schedule") is not None
        assert log.stop({"stop": 1}) is not None
        log.end("done", arrived=True, stops=1)
        assert "cannot make a run file" in str(log.problem)
    finally:
        folder.chmod(0o700)


def test_a_folder_that_cannot_be_made_is_reported_not_raised(tmp_path):
    # Works as root too: a file where the folder should be.
    (tmp_path / "runs").write_text("not a folder")
    log = PatrolRunLog(tmp_path / "runs", now=night_clock())
    assert log.start("night", scheduled=True, by="schedule") is not None
    assert log.stop({"stop": 1}) is not None
    assert log.end("done", arrived=True, stops=1) is not None
    assert "cannot make a run file" in str(log.problem)
    assert log.skipped("night", "busy") is not None
