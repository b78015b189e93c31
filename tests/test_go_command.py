"""`giraff-console go ROOM` from the shell: JSON, exit codes, and a clock that only
changes the wall time."""

from __future__ import annotations

import json

from giraff_console.cli import main

KEYS = {
    "arrived", "room", "why", "pose_estimate", "pose_true", "error_m", "heading_error_deg",
    "duration_s", "time_optimal_s", "stops", "max_jerk", "gear_jumps", "replans",
}  # fmt: skip


def go(capsys, *args: str) -> tuple[int, dict | None, str]:
    code = main(["go", *args])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


def test_go_arrives_and_reports_as_json(capsys):
    code, report, err = go(capsys, "day-room", "--sim-speed", "inf", "--json")
    assert code == 0
    assert set(report) == KEYS
    assert report["arrived"] and report["room"] == "day-room" and report["why"] == "done"
    assert report["error_m"] <= 0.03 and report["gear_jumps"] == 0
    assert report["duration_s"] <= 1.15 * report["time_optimal_s"]
    assert len(report["pose_true"]) == 3 and len(report["pose_estimate"]) == 3
    assert "go day-room done" in err


def test_a_faster_clock_changes_nothing_but_the_wall_time(capsys):
    _, fast, _ = go(capsys, "room-105", "--sim-speed", "inf", "--json")
    _, slower, _ = go(capsys, "room-105", "--sim-speed", "400", "--json")
    assert fast == slower


def test_an_unknown_room_exits_2_with_the_rooms(capsys):
    code, report, err = go(capsys, "attic", "--sim-speed", "inf")
    assert code == 2 and report is None
    assert "no room called 'attic'" in err and "kitchen" in err


def test_no_way_to_the_room_exits_1_with_the_reason(capsys):
    # A box in the dock's doorway: the robot sees it, and there is no other way out.
    code, report, err = go(capsys, "kitchen", "--sim-speed", "inf", "--json", "--block", "2,10.3")
    assert code == 1
    assert not report["arrived"] and "no way" in report["why"]
    assert "Traceback" not in err


def test_a_bad_block_is_a_usage_error(capsys):
    code, _, err = go(capsys, "kitchen", "--block", "2;3")
    assert code == 2 and "--block wants X,Y" in err
