"""The pose filter's estimates beside the control log: written at a modest rate, read back
exactly, and a damaged file reported line by line rather than refused."""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace
from pathlib import Path

import pytest

from giraff_console.recording.estimates import (
    ESTIMATES,
    RecordedEstimate,
    format_estimate,
    parse_estimate,
)
from giraff_console.recording.playback import open_estimates
from giraff_console.recording.session import RecordingSetup, SessionError, SessionRecorder

COVARIANCE = ((0.0025, 1e-4, -3e-4), (1e-4, 0.0036, 2e-4), (-3e-4, 2e-4, 0.0012))
ESTIMATE = RecordedEstimate(
    offset=1.25,
    pose=(1.5, -0.25, 0.3),
    odometry=(1.4, -0.2, 0.28),
    covariance=COVARIANCE,
    sigma_m=0.061,
    sigma_heading=0.035,
    ellipse=(0.061, 0.049, 1.2),
    landmarks=True,
    found=True,
    seen=(7, 12),
    rejected=(3,),
    corrected_at=1.2,
)


class Clock:
    def __init__(self) -> None:
        self.time = 100.0

    def __call__(self) -> float:
        return self.time


def at(offset: float, moved: float = 0.0, **changes: object) -> RecordedEstimate:
    """ESTIMATE at `offset`, both poses `moved` metres on along +x (as the odometry alone
    would carry the estimate, whose heading is near the odometry's)."""
    x, y, heading = ESTIMATE.pose
    ox, oy, oheading = ESTIMATE.odometry
    # The same step, taken in each pose's own frame.
    pose = (x + moved * math.cos(heading), y + moved * math.sin(heading), heading)
    odometry = (ox + moved * math.cos(oheading), oy + moved * math.sin(oheading), oheading)
    return replace(ESTIMATE, offset=offset, pose=pose, odometry=odometry, **changes)


def record(tmp_path: Path, estimates: list[RecordedEstimate]) -> Path:
    clock = Clock()
    warnings: list[str] = []
    recorder = SessionRecorder(tmp_path, RecordingSetup(port="none"), clock, warn=warnings.append)
    for estimate in estimates:
        recorder.estimate(estimate)
    assert recorder.close().startswith("0 log lines, ")
    assert warnings == []
    return recorder.path


def test_an_estimate_reads_back_exactly_as_it_was_written():
    read = parse_estimate(format_estimate(ESTIMATE))
    assert read == ESTIMATE
    assert read.covariance == COVARIANCE
    unknown = parse_estimate(format_estimate(replace(ESTIMATE, corrected_at=None)))
    assert unknown.corrected_at is None


def test_the_time_is_kept_to_the_millisecond_like_the_control_log():
    # 0.05 added nine times: what a 20 Hz loop's clock says at 0.45 s.
    offset = sum([0.05] * 9)
    assert offset != 0.45
    assert parse_estimate(format_estimate(replace(ESTIMATE, offset=offset))).offset == 0.45


def test_a_later_console_may_add_keys(tmp_path):
    body = json.loads(format_estimate(ESTIMATE))
    body["velocity"] = [0.1, 0.0]
    assert parse_estimate(json.dumps(body)) == ESTIMATE


def test_a_session_keeps_its_estimates_in_a_file_of_their_own(tmp_path):
    session = record(tmp_path, [ESTIMATE])
    assert (session / ESTIMATES).read_text().count("\n") == 1
    read = open_estimates(session)
    assert read.problems == []
    assert [replace(entry, line_no=0) for entry in read.entries] == [ESTIMATE]
    # The control log is the original console's format still, with nothing added.
    assert (session / "control.log").read_text() == ""


def test_estimates_that_only_follow_the_odometry_are_written_five_times_a_second(tmp_path):
    ticks = [at(i * 0.05, moved=i * 0.02) for i in range(41)]  # two seconds at 20 Hz
    entries = open_estimates(record(tmp_path, ticks)).entries
    assert [entry.offset for entry in entries] == pytest.approx([i * 0.2 for i in range(11)])


def test_an_estimate_the_odometry_cannot_explain_is_written_at_once(tmp_path):
    corrected = replace(at(0.10), pose=(1.52, -0.24, 0.31), corrected_at=0.1)
    seen_another = replace(at(0.15, corrected_at=0.1), pose=corrected.pose, seen=(7,))
    lost_track = replace(seen_another, offset=0.2, found=False)
    still_lost = replace(lost_track, offset=0.25)
    placed = replace(still_lost, offset=0.3, pose=(5.0, 5.0, 0.0))  # by the operator
    ticks = [at(0.0), at(0.05), corrected, seen_another, lost_track, still_lost, placed]
    offsets = [entry.offset for entry in open_estimates(record(tmp_path, ticks)).entries]
    # At 0.05 and 0.25 nothing that playback could not work out from the last one.
    assert offsets == pytest.approx([0.0, 0.10, 0.15, 0.2, 0.3])


def test_an_estimate_with_an_infinite_covariance_is_not_written(tmp_path):
    unplaced = replace(ESTIMATE, covariance=((math.inf, 0, 0), (0, math.inf, 0), (0, 0, 1.0)))
    assert open_estimates(record(tmp_path, [unplaced])).entries == []


def test_a_session_without_estimates_reads_as_none(tmp_path):
    session = tmp_path / "old"
    session.mkdir()
    (session / "control.log").write_text("   0.012:[G] v: 0.60000\n")
    assert open_estimates(session).entries == []
    assert open_estimates(session / "control.log").entries == []  # an original's log file


def test_a_cut_off_last_line_is_reported_and_the_rest_read(tmp_path):
    session = record(tmp_path, [at(0.0), at(0.2, moved=0.1), at(0.4, moved=0.2)])
    path = session / ESTIMATES
    text = path.read_text()
    path.write_text(text[: len(text) - 40])  # a crash in the middle of the third line
    read = open_estimates(session)
    assert [entry.offset for entry in read.entries] == [0.0, 0.2]
    assert [str(problem) for problem in read.problems] == ["line 3: incomplete last line, ignored"]


LINE = format_estimate(ESTIMATE)
MALFORMED = {
    "garbage": ("garbage", "not JSON"),
    "a list": ("[1, 2, 3]", "not a JSON object"),
    "no pose": ('{"t": 1.0}', "pose: not a list of 3 numbers"),
    "nested": ("[" * 100_000, "nested too deeply"),
    "negative time": (LINE.replace('"t":1.25', '"t":-1'), "t: before the session"),
    "NaN": (LINE.replace('"t":1.25', '"t":NaN'), "not JSON"),
    "huge float": (LINE.replace('"t":1.25', '"t":1e999'), "t: out of range"),
    "huge int": (LINE.replace('"t":1.25', '"t":' + "9" * 400), "t: out of range"),
    "not a flag": (LINE.replace('"found":true', '"found":1'), "found: not true or false"),
    "bad id": (LINE.replace('"seen":[7,12]', '"seen":[7,"x"]'), "seen: not a list of marker"),
    "4 columns": (LINE.replace("[[0.0025,", "[[0.0025,0,"), "covariance: not a list of 3 numbers"),
    "text": (LINE.replace('"sigma_m":0.061', '"sigma_m":"0.061"'), "sigma_m: not a number"),
}


@pytest.mark.parametrize(("line", "reason"), MALFORMED.values(), ids=MALFORMED.keys())
def test_a_malformed_line_is_reported_and_skipped(tmp_path, line, reason):
    session = record(tmp_path, [at(0.0), at(2.0)])
    path = session / ESTIMATES
    first, second = path.read_text().splitlines()
    path.write_text(f"{first}\n{line}\n{second}\n")
    read = open_estimates(session)
    assert [entry.offset for entry in read.entries] == [0.0, 2.0]
    [problem] = read.problems
    assert problem.line_no == 2 and reason in problem.reason and problem.reason.endswith("skipped")


def test_an_estimate_whose_time_goes_backwards_is_skipped(tmp_path):
    session = record(tmp_path, [at(0.0), at(2.0)])
    path = session / ESTIMATES
    first, second = path.read_text().splitlines()
    path.write_text(f"{first}\n{second}\n{format_estimate(at(1.0))}\n")
    read = open_estimates(session)
    assert [entry.offset for entry in read.entries] == [0.0, 2.0]
    assert [str(problem) for problem in read.problems] == ["line 3: time goes backwards; skipped"]


def test_bytes_that_are_not_text_are_a_bad_line(tmp_path):
    session = record(tmp_path, [ESTIMATE])
    (session / ESTIMATES).write_bytes(b"\xff\xfe" * 10 + b"\n")
    [problem] = open_estimates(session).problems
    assert problem.reason.startswith("not JSON")


def test_an_unreadable_estimates_file_is_a_session_error(tmp_path, monkeypatch):
    session = record(tmp_path, [ESTIMATE])
    path = session / ESTIMATES
    opened = os.open

    def refuse(name, *args, **kwargs):
        if Path(name) == path:
            raise PermissionError(13, "Permission denied")
        return opened(name, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)
    with pytest.raises(SessionError, match=f"cannot read {path}: Permission denied"):
        open_estimates(session)
