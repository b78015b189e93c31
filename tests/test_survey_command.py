"""`giraff-console survey` (issue 25, item 2): the simulated robot tours a small plan
whose markers were taken out, finds the markers hung in the simulated building, and
writes them into the plan within centimetres of where they hang."""

from __future__ import annotations

import json
import math

import pytest

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.landmark_placement import place_markers, write_landmarks

# An office and a hall through a door, the dock in the office.
PLAN = """name: two rooms
rooms:
  office: {at: [2, 2], heading: 0, outline: [[0, 0], [4, 0], [4, 4], [0, 4]]}
  hall: {at: [7, 2], outline: [[4, 0], [10, 0], [10, 4], [4, 4]]}
doors:
- {between: [office, hall], at: [4, 2], width: 0.9}
start: office
"""


@pytest.fixture
def building(tmp_path):
    """The plan without markers, and a copy with markers placed: the building's truth."""
    hung = tmp_path / "hung.yaml"
    hung.write_text(PLAN)
    write_landmarks(load_floorplan(hung), place_markers(load_floorplan(hung)).landmarks)
    plan = tmp_path / "plan.yaml"
    plan.write_text(PLAN)
    return plan, load_floorplan(hung)


def survey(capsys, plan, hung, *more: str) -> tuple[int, dict, str]:
    code = main(["survey", "--sim", "--sim-speed", "inf", "--floorplan", str(plan),
                 "--sim-markers", str(hung.path), "--json", *more])  # fmt: skip
    out, err = capsys.readouterr()
    return code, json.loads(out.splitlines()[-1]), err


def test_a_survey_finds_the_markers_and_writes_them_where_they_hang(building, capsys):
    plan, hung = building
    code, report, err = survey(capsys, plan, hung)
    assert code == 0, err
    truth = {marker.id: marker for marker in hung.landmarks.markers}
    written = load_floorplan(plan).landmarks
    assert written is not None and report["written"] == str(plan)
    assert {marker.id for marker in written.markers} == set(truth)
    for marker in written.markers:
        assert math.dist(marker.at, truth[marker.id].at) <= 0.05, marker
        # Flat on its wall: square to it, as the plan's checks ask (within 2 degrees).
        assert abs((marker.facing - truth[marker.id].facing + 180) % 360 - 180) <= 0.05
        assert marker.sigma is not None and marker.height == truth[marker.id].height
    assert "Traceback" not in err


def test_a_dry_run_writes_nothing_and_a_survey_of_some_rooms_keeps_the_rest(building, capsys):
    plan, hung = building
    code, report, _ = survey(capsys, plan, hung, "--dry-run")
    assert code == 0 and report["written"] is None and report["markers"]
    assert load_floorplan(plan).landmarks is None
    # The plan with the building's markers, the office's west one written 0.3 m off
    # along its wall: a survey of the office alone puts it right, and keeps the hall's
    # (which it does not see from the office) as they were.
    truth = {marker.id: marker for marker in hung.landmarks.markers}
    west = next(m for m in hung.landmarks.markers if m.at[0] == 0.0)
    text = hung.path.read_text()
    plan.write_text(text.replace(f"at: [0, {west.at[1]:g}]", f"at: [0, {west.at[1] + 0.3:g}]"))
    assert load_floorplan(plan).landmarks.markers != hung.landmarks.markers
    code, report, err = survey(capsys, plan, hung, "--rooms", "office")
    assert code == 0, err
    written = {marker.id: marker for marker in load_floorplan(plan).landmarks.markers}
    assert set(written) == set(truth)
    assert math.dist(written[west.id].at, west.at) <= 0.05
    hall = [i for i, m in truth.items() if m.at[0] > 5.0]
    assert hall and all(written[i] == truth[i] for i in hall)


def test_a_survey_refuses_without_a_start_room(tmp_path, capsys):
    plan = tmp_path / "plan.yaml"
    plan.write_text(PLAN.replace("start: office\n", ""))
    code = main(["survey", "--sim", "--sim-speed", "inf", "--floorplan", str(plan)])
    assert code == 2
    assert "start" in capsys.readouterr().err
