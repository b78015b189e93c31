"""`giraff-console go ROOM` from the shell: JSON, exit codes, and a clock that only
changes the wall time."""

from __future__ import annotations

import json

import pytest

from giraff_console.cli.main import main
from giraff_console.runtime.board import built_in_simulator

# A small camera, a few frames a second: enough to find the robot by, and quick.
SMALL_EYE = ("--eye-size", "400x300", "--eye-fps", "5")

KEYS = {
    "arrived", "outcome", "room", "why", "detail", "pose_estimate", "pose_true", "error_m",
    "heading_error_deg", "duration_s", "time_optimal_s", "stops", "max_jerk", "gear_jumps",
    "replans", "contacts", "since_fix_m",
}  # fmt: skip


def go(capsys, *args: str) -> tuple[int, dict | None, str]:
    code = main(["go", *args])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


def test_go_arrives_and_reports_as_json(capsys):
    # Dead reckoning: on a perfect simulator, what the drive does by itself; nothing
    # confirms where it ends, so it says so (exit 3).
    code, report, err = go(capsys, "day-room", "--sim-speed", "inf", "--json", "--no-landmarks")
    assert code == 3
    assert set(report) == KEYS
    assert report["outcome"] == "arrived_unverified" and not report["arrived"]
    assert report["room"] == "day-room" and report["why"] == "done"
    assert "odometry alone" in report["detail"] and report["since_fix_m"] > 30
    assert report["error_m"] <= 0.03 and report["gear_jumps"] == 0
    assert report["duration_s"] <= 1.15 * report["time_optimal_s"]
    assert len(report["pose_true"]) == 3 and len(report["pose_estimate"]) == 3
    assert "go day-room done" in err


def test_a_faster_clock_changes_nothing_but_the_wall_time(capsys):
    # The camera's frames too fall at the same virtual times: markers and all.
    _, fast, _ = go(capsys, "room-105", "--sim-speed", "inf", "--json", *SMALL_EYE)
    _, slower, _ = go(capsys, "room-105", "--sim-speed", "400", "--json", *SMALL_EYE)
    assert fast == slower
    assert fast["arrived"] and fast["outcome"] == "arrived" and fast["error_m"] <= 0.03


def test_faults_off_keeps_the_imperfect_odometry_but_not_its_stalls_and_estops():
    board = built_in_simulator(None, 3, faults=False).board
    quiet = board.config.imperfections
    assert quiet.stall_rate == quiet.estop_rate == 0
    assert quiet.move_error_m > 0 and quiet.caster_drift_deg > 0 and quiet.seed == 3
    assert built_in_simulator(None, 3, faults=True).board.config.imperfections.stall_rate > 0


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (("--sim-start", "attic"), "--sim-start: no room called 'attic'"),
        (("--eye-size", "big"), "--eye-size wants WxH"),
        (("--eye-fps", "0"), "--eye-fps must be a positive number"),
        (("--port", "/dev/null", "--imperfect"), "--imperfect: only with the simulator"),
    ],
)
def test_bad_simulator_options_are_usage_errors(capsys, options, message):
    code, report, err = go(capsys, "kitchen", *options)
    assert code == 2 and report is None and message in err


def test_a_misspelt_room_exits_2_with_the_room_meant(capsys):
    code, report, err = go(capsys, "kitchn", "--sim-speed", "inf")
    assert code == 2 and report is None
    assert "no room called 'kitchn': did you mean kitchen?" in err


def test_an_unknown_room_exits_2_saying_where_the_rooms_are(capsys):
    code, report, err = go(capsys, "attic", "--sim-speed", "inf")
    assert code == 2 and report is None
    assert "no room called 'attic', nor any like it among the 32 rooms" in err
    assert "giraff-console floorplan show" in err and "care-home.yaml" in err


def test_no_way_to_the_room_exits_1_with_the_reason(capsys):
    # A box in the dock's doorway: the robot sees it, and there is no other way out.
    code, report, err = go(capsys, "kitchen", "--sim-speed", "inf", "--json", "--block", "2,10.3",
                           "--no-landmarks")  # fmt: skip
    assert code == 1
    assert not report["arrived"] and "no way" in report["why"]
    assert "Traceback" not in err


def test_a_bad_block_is_a_usage_error(capsys):
    code, _, err = go(capsys, "kitchen", "--block", "2;3")
    assert code == 2 and "--block wants X,Y" in err
