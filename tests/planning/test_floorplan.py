"""Loading floor plans, and the mistakes in hand-written ones that must be reported."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from giraff_console.planning.floorplan import (
    Door,
    FloorPlanError,
    Problem,
    check_floorplan,
    load_floorplan,
)

FIXTURES = Path(__file__).parent / "fixtures"
ROOT = Path(__file__).resolve().parents[2]

TWO_ROOMS = """\
name: Two rooms
rooms:
  a:
    at: [1, 1]
  b:
    at: [3, 1]
doors:
  - between: [a, b]
    at: [2, 1]
"""


def problems_in(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "plan.yaml"
    path.write_text(text)
    return [str(problem).removeprefix(f"{path}:") for problem in check_floorplan(path)]


def small_home(tmp_path: Path, old: str = "", new: str = "") -> Path:
    """The small home fixture with one piece of text replaced, next to its grid image."""
    text = (FIXTURES / "small-home.yaml").read_text()
    assert old in text
    shutil.copy(FIXTURES / "small-home.pgm", tmp_path / "small-home.pgm")
    path = tmp_path / "plan.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_the_small_home_loads_with_defaults_filled_in():
    plan = load_floorplan(FIXTURES / "small-home.yaml")
    assert plan.name == "Small test home"
    assert list(plan.rooms) == ["hall", "office", "lounge", "kitchen", "store"]
    assert plan.rooms["office"].label == "office"
    assert plan.rooms["office"].heading == 90.0
    assert plan.rooms["hall"].heading is None
    assert plan.rooms["hall"].outline == ((0, 0), (10, 0), (10, 2), (0, 2))
    assert plan.doors[0] == Door("office-hall", ("office", "hall"), (2.0, 2.0), 0.9, True)
    assert plan.doors[4].open is False
    assert plan.doors[5].id == "store-door"
    assert plan.grid is not None and plan.grid.image == FIXTURES / "small-home.pgm"
    assert (plan.grid.negate, plan.grid.occupied_thresh, plan.grid.free_thresh) == (0, 0.65, 0.196)
    assert plan.start == "hall"


def test_the_example_care_home_has_no_problems():
    assert check_floorplan(ROOT / "giraff_console/floorplans/care-home.yaml") == []


def test_a_problem_prints_as_path_line_message():
    assert str(Problem(Path("f.yaml"), 3, "bad")) == "f.yaml:3: bad"
    assert str(Problem(Path("f.yaml"), None, "bad")) == "f.yaml: bad"


def test_loading_a_bad_plan_raises_one_error_listing_every_problem(tmp_path):
    path = tmp_path / "plan.yaml"
    path.write_text(TWO_ROOMS.replace("[1, 1]", "[1, x]").replace("[a, b]", "[a, c]"))
    with pytest.raises(FloorPlanError) as caught:
        load_floorplan(path)
    assert len(caught.value.problems) == 2
    assert str(caught.value).splitlines() == [
        f"{path}:4: rooms.a.at[1] should be a number, not 'x'",
        f"{path}:8: door 0 leads to an unknown room 'c'",
    ]


def test_a_missing_file_is_reported_not_raised(tmp_path):
    (problem,) = check_floorplan(tmp_path / "nowhere.yaml")
    assert "cannot read it" in problem.message


def test_text_that_is_not_yaml(tmp_path):
    (problem,) = problems_in(tmp_path, "name: [unclosed\nrooms: {}\n")
    assert problem == (
        "2: not YAML: while parsing a flow sequence, did not find expected ',' or ']'"
    )


def test_a_file_that_is_not_a_mapping(tmp_path):
    assert problems_in(tmp_path, "- a\n- b\n") == [
        " the file should be a mapping of keys, not ['a', 'b']"
    ]


def test_a_missing_required_key(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("name: Two rooms\n", "")) == [
        " missing key name"
    ]


def test_an_unknown_key_is_a_typo(tmp_path):
    text = TWO_ROOMS.replace("at: [2, 1]", "at: [2, 1]\n    widht: 1")
    assert problems_in(tmp_path, text) == [
        "10: unknown key doors[0].widht (expected between, at, width, open, id)"
    ]


def test_a_point_that_is_not_a_pair(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("[3, 1]", "[3]")) == [
        "6: rooms.b.at should be a pair of numbers [x, y] in metres, not [3]"
    ]


def test_an_infinite_coordinate(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("[3, 1]", "[.inf, 1]")) == [
        "6: rooms.b.at[0] should be a finite number, not inf"
    ]


def test_a_negative_door_width(tmp_path):
    text = TWO_ROOMS.replace("at: [2, 1]", "at: [2, 1]\n    width: -1")
    assert problems_in(tmp_path, text) == ["10: doors[0].width is -1, out of range [0.01, 100.0]"]


def test_a_door_to_an_unknown_room(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("[a, b]", "[a, kitchen]")) == [
        "8: door 0 leads to an unknown room 'kitchen'"
    ]


def test_a_door_from_a_room_to_itself(tmp_path):
    problems = problems_in(tmp_path, TWO_ROOMS.replace("[a, b]", "[a, a]"))
    assert problems[0] == "8: door 0 leads from 'a' to itself"


def test_two_doors_with_the_same_id(tmp_path):
    door = "  - between: [a, b]\n    at: [2, 1.5]\n"
    text = TWO_ROOMS + door + door
    assert problems_in(tmp_path, text) == [
        "10: duplicate door id 'a-b': give one of them another id",
        "12: duplicate door id 'a-b': give one of them another id",
    ]


def test_a_door_id_that_is_also_a_room_id(tmp_path):
    text = TWO_ROOMS.replace("at: [2, 1]", "at: [2, 1]\n    id: b")
    assert problems_in(tmp_path, text) == ["8: door id 'b' is also a room id"]


def test_a_room_written_twice(tmp_path):
    # PyYAML keeps the second silently; the first might be the one the writer meant.
    text = TWO_ROOMS.replace("  b:\n", "  a:\n")
    assert problems_in(tmp_path, text)[0] == "5: duplicate key rooms.a"


def test_a_door_off_the_shared_wall(tmp_path):
    path = small_home(tmp_path, "at: [7, 2]", "at: [7, 2.5]")
    assert [str(p).removeprefix(f"{path}:") for p in check_floorplan(path)] == [
        "29: door 'lounge-hall' at [7.0, 2.5] is 0.50 m from the walls of 'lounge' (at most 0.1 m)",
        "29: door 'lounge-hall' at [7.0, 2.5] is 0.50 m from the walls of 'hall' (at most 0.1 m)",
    ]


def test_a_door_within_the_tolerance_of_both_walls(tmp_path):
    path = small_home(tmp_path, "at: [7, 2]", "at: [7, 2.08]")
    assert check_floorplan(path) == []


def test_every_unreachable_room_is_reported(tmp_path):
    text = TWO_ROOMS.replace("doors:", "  c:\n    at: [5, 1]\n  d:\n    at: [7, 1]\ndoors:")
    assert problems_in(tmp_path, text) == [
        "7: room 'c' cannot be reached from 'a': no chain of doors leads to it",
        "9: room 'd' cannot be reached from 'a': no chain of doors leads to it",
    ]


def test_reachability_is_from_start_and_counts_closed_doors(tmp_path):
    text = TWO_ROOMS.replace("at: [2, 1]", "at: [2, 1]\n    open: false")
    text += "start: b\n"
    assert problems_in(tmp_path, text) == []
    text = text.replace("  a:\n", "  c:\n    at: [9, 9]\n  a:\n")
    assert problems_in(tmp_path, text) == [
        "3: room 'c' cannot be reached from 'b': no chain of doors leads to it"
    ]


def test_start_naming_an_unknown_room(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS + "start: attic\n") == [
        "10: start names an unknown room 'attic'"
    ]


def test_a_missing_grid_image(tmp_path):
    path = small_home(tmp_path, "image: small-home.pgm", "image: gone.pgm")
    (problem,) = check_floorplan(path)
    assert problem.line == 42
    assert problem.message == f"grid image '{tmp_path / 'gone.pgm'}' is missing"


def test_an_unreadable_grid_image(tmp_path):
    path = small_home(tmp_path, "image: small-home.pgm", "image: broken.pgm")
    (tmp_path / "broken.pgm").write_bytes(b"P5\nnot an image")
    (problem,) = check_floorplan(path)
    assert problem.message.endswith(
        "broken.pgm': its header should give the width, the height and the largest value, "
        "as whole numbers"
    )


def test_a_room_point_on_an_occupied_cell(tmp_path):
    # The pillar is 0.5-1.0 m up from the bottom edge: row 14 counted from the image's top.
    path = small_home(tmp_path, "at: [12, 3]", "at: [12.2, 0.7]")
    assert [p.message for p in check_floorplan(path)] == [
        "room 'kitchen' at [12.2, 0.7] is on an occupied cell (row 14, column 24 of small-home.pgm)"
    ]


def test_a_room_point_near_the_top_is_not_mirrored_onto_the_pillar(tmp_path):
    path = small_home(tmp_path, "at: [12, 3]", "at: [12.2, 7.2]")
    assert check_floorplan(path) == []


def test_a_negated_grid_reads_dark_as_free(tmp_path):
    path = small_home(tmp_path, "resolution: 0.5", "resolution: 0.5\n  negate: 1")
    # Every room point and door is on a light (free) pixel, which negate makes occupied.
    messages = [problem.message for problem in check_floorplan(path)]
    assert sum(message.startswith("room ") for message in messages) == 5
    assert sum(message.startswith("door ") for message in messages) == 6
    assert all("on an occupied cell" in message for message in messages)


def test_a_room_point_off_the_grid(tmp_path):
    path = small_home(tmp_path, "at: [2, 7]", "at: [2, 8.2]")
    assert [p.message for p in check_floorplan(path)] == [
        "room 'store' at [2.0, 8.2] is off the grid"
    ]


def test_a_plan_of_one_room_needs_no_doors(tmp_path):
    path = tmp_path / "plan.yaml"
    path.write_text("name: Flat\nrooms:\n  flat:\n    at: [0, 0]\ndoors:\n")
    assert load_floorplan(path).doors == []


def test_a_room_id_that_cannot_be_typed(tmp_path):
    # Only the room is reported, not the door id "a-room b" made from it.
    text = TWO_ROOMS.replace("  b:", "  room b:").replace("[a, b]", "[a, room b]")
    assert problems_in(tmp_path, text) == [
        "5: rooms.room b should be an id of letters, digits, '-' and '_' (up to 64), not 'room b'",
    ]


def test_a_room_that_is_not_a_mapping(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("  b:\n    at: [3, 1]", "  b: [3, 1]")) == [
        "5: rooms.b should be a mapping of keys, not [3, 1]"
    ]


def test_a_door_id_that_cannot_be_typed(tmp_path):
    text = TWO_ROOMS.replace("at: [2, 1]", "at: [2, 1]\n    id: front door")
    assert problems_in(tmp_path, text) == [
        "10: doors[0].id should be an id of letters, digits, '-' and '_' (up to 64),"
        " not 'front door'"
    ]
