"""`giraff-console patrol NAME` from the shell: a line of JSON per stop and one for the
patrol, `go`'s exit codes, rooms and taught routes, and a marker the gate rejects."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

from giraff_console.cli.main import main
from giraff_console.data_folders import patrol_runs
from giraff_console.missions.patrol_log import list_runs

# A small camera, a few frames a second: enough to find the robot by, and quick.
SMALL_EYE = ("--eye-size", "400x300", "--eye-fps", "5")
STOP_KEYS = {
    "stop", "round", "room", "route", "arrived", "outcome", "why", "detail", "pose_estimate",
    "pose_true", "error_m", "heading_error_deg", "sigma_m", "sigma_heading_deg", "found",
    "seen", "rejected", "since_fix_m", "basis", "duration_s", "t_s", "max_jerk",
}  # fmt: skip


def write_patrol(folder, name, stops, rounds=1):
    path = folder / f"{name}.patrol.yaml"
    path.write_text(yaml.safe_dump({"rounds": rounds, "stops": stops}))
    return path


def patrol(capsys, *args: str) -> tuple[int, list[dict], str]:
    code = main(["patrol", *args])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines()], err


def test_a_patrol_of_rooms_reports_each_stop_and_the_patrol_as_json_lines(tmp_path):
    path = write_patrol(tmp_path, "two", [{"room": "nurse-station"}, {"room": "dock"}])
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "patrol", str(path), "--sim",
         "--sim-speed", "inf", "--json", *SMALL_EYE],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    *stops, summary = [json.loads(line) for line in result.stdout.splitlines()]
    assert [(s["stop"], s["room"], s["arrived"], s["why"]) for s in stops] == [
        (1, "nurse-station", True, "done"),
        (2, "dock", True, "done"),
    ]
    for stop in stops:
        assert set(stop) == STOP_KEYS
        assert stop["error_m"] <= 0.03 and stop["heading_error_deg"] <= 1.0
        assert len(stop["pose_true"]) == 3 and len(stop["pose_estimate"]) == 3
        assert stop["found"] and stop["sigma_m"] > 0
        assert 0 < stop["max_jerk"] <= 1.0  # the settings' limit, markers or not
    assert stops[1]["t_s"] > stops[0]["t_s"] > 0
    assert summary["patrol"] == "two" and summary["why"] == "done"
    assert (summary["rounds"], summary["stops"], summary["arrived"]) == (1, 2, 2)
    assert summary["landmarks"] and summary["eye"]["frames"] > 0
    assert summary["eye"]["detect_ms_per_frame"] > 0 and summary["markers_used"]


def test_taught_routes_drive_headless_and_are_measured_from_their_path_end(tmp_path, capsys):
    # From the dock, at (2, 7) facing +y: a quarter metre straight on, then back.
    route = {
        "format": 1, "taught": "2024-05-01T10:00:00+02:00", "duration": 4.0,
        "settings": {"mode": "0", "a": "0.5", "v": "0.3"},
        "commands": [[0.0, "set p 0.5"]],
        "path": [[0.0, 2.0, 7.0, 90.0], [4.0, 2.0, 7.25, 90.0]],
    }  # fmt: skip
    (tmp_path / "out.yaml").write_text(yaml.safe_dump(route))
    write_patrol(tmp_path, "out-and-back", [{"route": "out"}, {"room": "dock"}], rounds=2)
    code, lines, _ = patrol(capsys, "out-and-back", "--routes", str(tmp_path), "--sim",
                            "--sim-speed", "inf", "--json", "--no-landmarks")  # fmt: skip
    # Every stop reached, none confirmed by a marker: dead reckoning's exit code.
    assert code == 3
    *stops, summary = lines
    assert [(s["round"], s["route"] or s["room"]) for s in stops] == [
        (1, "out"), (1, "dock"), (2, "out"), (2, "dock"),
    ]  # fmt: skip
    assert all(s["outcome"] == "arrived_unverified" and s["error_m"] <= 0.03 for s in stops)
    assert not summary["landmarks"] and summary["eye"] is None


def test_a_stop_that_cannot_be_reached_is_reported_and_the_patrol_goes_on(tmp_path, capsys):
    # A box in the dock's doorway: the robot sees it, and there is no other way out of
    # the dock room. The kitchen cannot be reached; the dock, where it stands, can.
    write_patrol(tmp_path, "boxed-in", [{"room": "kitchen"}, {"room": "dock"}], rounds=2)
    code, lines, err = patrol(capsys, "boxed-in", "--routes", str(tmp_path), "--sim",
                              "--sim-speed", "inf", "--json", "--no-landmarks",
                              "--block", "2,10.3")  # fmt: skip
    assert code == 1
    *stops, summary = lines
    assert [(s["round"], s["room"], s["outcome"]) for s in stops] == [
        (1, "kitchen", "blocked"), (1, "dock", "arrived_unverified"),
        (2, "kitchen", "blocked"), (2, "dock", "arrived_unverified"),
    ]  # fmt: skip
    assert "no way" in stops[0]["detail"] and stops[0]["error_m"] > 10
    assert summary["why"] == "done" and (summary["stops"], summary["failed"]) == (4, 2)
    assert "going on to the next stop" in err and "Traceback" not in err


def test_a_patrol_told_not_to_carry_on_ends_at_its_first_failed_stop(tmp_path, capsys):
    path = write_patrol(tmp_path, "strict", [{"room": "kitchen"}, {"room": "dock"}], rounds=2)
    path.write_text(path.read_text() + "carry_on: false\n")
    code, lines, err = patrol(capsys, "strict", "--routes", str(tmp_path), "--sim",
                              "--sim-speed", "inf", "--json", "--no-landmarks",
                              "--block", "2,10.3")  # fmt: skip
    assert code == 1
    stop, summary = lines
    assert (stop["stop"], stop["room"], stop["arrived"]) == (1, "kitchen", False)
    assert "no way" in stop["why"] and stop["error_m"] > 10
    assert summary["why"] == stop["why"] and (summary["stops"], summary["arrived"]) == (4, 0)
    assert "Traceback" not in err


def test_a_marker_moved_along_its_wall_is_rejected_and_the_robot_still_arrives(tmp_path, capsys):
    # Marker 109 is in the nurse station, in view on the way in; moved 1 m, but not in
    # the plan, it disagrees with every other marker.
    write_patrol(tmp_path, "nurse", [{"room": "nurse-station"}])
    code, (stop, summary), _ = patrol(capsys, "nurse", "--routes", str(tmp_path), "--sim",
                                      "--sim-speed", "inf", "--json", "--move-marker",
                                      "109:1", *SMALL_EYE)  # fmt: skip
    assert code == 0 and stop["arrived"] and stop["error_m"] <= 0.03
    assert 109 in summary["markers_rejected"] and 109 not in summary["markers_used"]


@pytest.mark.parametrize(
    ("stops", "message"),
    [
        (None, "no patrol missing"),
        ([{"room": "attic"}], "no room called 'attic'"),
        ("rounds: 1\nstops: nothing\n", "stops should be a list"),
    ],
)
def test_an_unknown_patrol_or_room_or_a_bad_file_exits_2(tmp_path, capsys, stops, message):
    if isinstance(stops, str):
        (tmp_path / "missing.patrol.yaml").write_text(stops)
    elif stops is not None:
        write_patrol(tmp_path, "missing", stops)
    code, lines, err = patrol(capsys, "missing", "--routes", str(tmp_path), "--sim")
    assert code == 2 and lines == []
    assert message in err


def test_simulator_options_are_refused_on_a_real_robot(tmp_path, capsys):
    write_patrol(tmp_path, "nurse", [{"room": "nurse-station"}])
    code, _, err = patrol(capsys, "nurse", "--routes", str(tmp_path), "--port", "/dev/null",
                          "--move-marker", "108:1")  # fmt: skip
    assert code == 2 and "--move-marker: only with the simulator" in err


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ("108:100", "would slide off its wall"),
        ("999:1", "no marker 999"),
        ("108", "wants ID:DX"),
    ],
)
def test_a_marker_that_cannot_be_moved_so_is_a_usage_error(tmp_path, capsys, option, message):
    write_patrol(tmp_path, "nurse", [{"room": "nurse-station"}])
    code, _, err = patrol(capsys, "nurse", "--routes", str(tmp_path), "--sim",
                          "--move-marker", option)  # fmt: skip
    assert code == 2 and message in err


def test_a_patrol_run_from_the_shell_is_logged_where_patrols_lists_it(tmp_path, capsys):
    """Issue 26: headless patrol runs were missing from `giraff-console patrols`."""
    path = write_patrol(tmp_path, "short", [{"room": "nurse-station"}])
    code, lines, err = patrol(capsys, str(path), "--sim", "--sim-speed", "inf", "--json",
                              "--no-landmarks")  # fmt: skip
    assert code == 3, err  # reached by the odometry alone, unconfirmed
    assert lines[-1]["outcome"] == "arrived_unverified"
    [run] = list_runs(patrol_runs())
    assert (run.patrol, run.state, run.stops, run.by) == ("short", "ended", 1, "the patrol command")
    assert main(["patrols"]) == 0
    assert "short  by the patrol command: ended, 1 stop, every stop reached" in (
        capsys.readouterr().out
    )
