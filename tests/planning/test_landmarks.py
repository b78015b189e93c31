"""The `landmarks:` key of a floor plan: its schema, and the checks `floorplan check` runs
on the markers (each reported at its line)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from giraff_console.planning.floorplan import (
    Landmarks,
    Marker,
    check_floorplan,
    load_floorplan,
)
from giraff_console.planning.landmark_placement import write_landmarks
from giraff_console.planning.landmarks import (
    FACING_TOLERANCE_DEG,
    aruco_dictionary,
    id_count,
    marker_beliefs,
    marker_image,
    marker_poses,
    where_it_goes,
)
from giraff_console.robot.marker_map import MarkerState

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "giraff_console/floorplans/care-home.yaml"

# Two 4 m square rooms side by side, a door between them at (4, 2); one marker in room a
# on its north wall, facing south into it. Line 18 is the marker's `- id:`.
TWO_ROOMS = """\
name: Two rooms
rooms:
  a:
    at: [2, 2]
    outline: [[0, 0], [4, 0], [4, 4], [0, 4]]
  b:
    at: [6, 2]
    outline: [[4, 0], [8, 0], [8, 4], [4, 4]]
doors:
  - between: [a, b]
    at: [4, 2]
landmarks:
  family: apriltag_36h11
  size: 0.16
  markers:
    - id: 1
      at: [2, 4]
      height: 1.1
      facing: 270
"""
MARKER_LINE = 16


def problems_in(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "plan.yaml"
    path.write_text(text)
    return [str(problem).removeprefix(f"{path}:") for problem in check_floorplan(path)]


def with_marker(marker: str, size: str = "0.16") -> str:
    """The two rooms with a second marker, written as one flow mapping, on line 20."""
    return TWO_ROOMS.replace("size: 0.16", f"size: {size}") + f"    - {marker}\n"


def load_text(tmp_path: Path, text: str):
    path = tmp_path / "plan.yaml"
    path.write_text(text)
    return load_floorplan(path)


def test_the_two_rooms_load_with_their_marker(tmp_path):
    plan = load_text(tmp_path, TWO_ROOMS)
    assert plan.landmarks == Landmarks("apriltag_36h11", 0.16, (Marker(1, (2.0, 4.0), 1.1, 270.0),))


def test_a_plan_without_the_key_has_no_landmarks():
    plan = load_floorplan(ROOT / "tests/planning/fixtures/small-home.yaml")
    assert plan.landmarks is None


def test_the_example_care_home_has_markers_that_pass_every_check():
    plan = load_floorplan(EXAMPLE)
    assert plan.landmarks is not None
    assert plan.landmarks.family == "apriltag_36h11" and plan.landmarks.size == 0.16
    ids = [marker.id for marker in plan.landmarks.markers]
    assert len(ids) == len(set(ids)) > 2 * len(plan.doors)


def test_a_facing_is_read_as_degrees_from_0_to_360(tmp_path):
    plan = load_text(tmp_path, TWO_ROOMS.replace("facing: 270", "facing: -90"))
    assert plan.landmarks is not None and plan.landmarks.markers[0].facing == 270.0


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        ("    - id: 1\n", "    - id: seven\n", f"{MARKER_LINE}: landmarks.markers[0].id should be "
                                               "a whole number from 0, not 'seven'"),
        ("    - id: 1\n", "    - id: -1\n", f"{MARKER_LINE}: landmarks.markers[0].id should be"),
        ("    - id: 1\n", "    - id: true\n", f"{MARKER_LINE}: landmarks.markers[0].id should be"),
        ("at: [2, 4]", "at: [2]", f"{MARKER_LINE + 1}: landmarks.markers[0].at should be a pair"),
        ("height: 1.1", "height: 3", f"{MARKER_LINE + 2}: landmarks.markers[0].height is 3, "
                                     "out of range [0.3, 2.2]"),
        ("facing: 270", "facing: south", f"{MARKER_LINE + 3}: landmarks.markers[0].facing "
                                         "should be a number"),
        ("      facing: 270\n", "", f"{MARKER_LINE}: missing key landmarks.markers[0].facing"),
        ("facing: 270", "facing: 270\n      colour: black",
         f"{MARKER_LINE + 4}: unknown key landmarks.markers[0].colour"),
        ("size: 0.16", "size: 2", "14: landmarks.size is 2, out of range [0.05, 0.3]"),
        ("size: 0.16", "size: small", "14: landmarks.size should be a number"),
        ("  family: apriltag_36h11\n", "", "12: missing key landmarks.family"),
        ("  family: apriltag_36h11", "  family: 7", "13: landmarks.family should be text"),
    ],
)  # fmt: skip
def test_mistakes_in_the_schema_are_reported_at_their_line(tmp_path, old, new, expected):
    assert old in TWO_ROOMS
    problems = problems_in(tmp_path, TWO_ROOMS.replace(old, new, 1))
    assert any(problem.startswith(expected) for problem in problems), problems


def test_landmarks_and_markers_of_the_wrong_kind_are_reported(tmp_path):
    head = TWO_ROOMS.split("landmarks:")[0]
    assert problems_in(tmp_path, head + "landmarks: [1]\n") == [
        "12: landmarks should be a mapping of keys, not [1]"
    ]
    text = TWO_ROOMS.split("  markers:")[0] + "  markers: 3\n"
    assert problems_in(tmp_path, text) == [
        "15: landmarks.markers should be a list of markers, not 3"
    ]


def test_an_empty_list_of_markers_is_no_markers_yet(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.split("    - id: 1")[0]) == []


def test_an_unknown_family_is_reported_with_the_known_ones(tmp_path):
    problems = problems_in(tmp_path, TWO_ROOMS.replace("apriltag_36h11", "tag36h11"))
    assert problems == [
        "13: unknown marker family 'tag36h11': a cv2.aruco predefined dictionary, one of "
        + ", ".join(sorted(problems[0].split("one of ")[1].split(", ")))
    ]
    assert "apriltag_36h11" in problems[0] and "4x4_50" in problems[0]


def test_aruco_dictionary_names_opencvs_dictionaries_in_lower_case():
    assert id_count("apriltag_36h11") == 587
    assert aruco_dictionary("4x4_50").bytesList.shape[0] == 50
    for name in ("APRILTAG_36H11", "DICT_APRILTAG_36h11", "tag36h11", ""):
        with pytest.raises(ValueError, match="unknown marker family"):
            aruco_dictionary(name)


def test_an_id_beyond_the_family_is_reported(tmp_path):
    assert problems_in(tmp_path, TWO_ROOMS.replace("id: 1", "id: 586")) == []
    problems = problems_in(tmp_path, TWO_ROOMS.replace("id: 1", "id: 587"))
    assert problems == [f"{MARKER_LINE}: marker id 587 is beyond apriltag_36h11's 587 ids "
                        "(0 to 586)"]  # fmt: skip


def test_a_duplicate_id_is_reported_at_the_second(tmp_path):
    problems = problems_in(tmp_path, with_marker("{id: 1, at: [2, 0], height: 1.1, facing: 90}"))
    assert problems == ["20: duplicate marker id 1 (also landmarks.markers[0]): the robot tells "
                        "markers apart by id alone"]  # fmt: skip


def test_a_marker_off_every_wall_is_reported_with_its_distance(tmp_path):
    problems = problems_in(tmp_path, with_marker("{id: 2, at: [2, 3.5], height: 1.1, facing: 270}"))
    assert problems == ["20: marker 2 at [2.0, 3.5] is 0.50 m from the nearest wall (at most "
                        "0.05 m): markers hang on walls"]  # fmt: skip
    # A few centimetres off, as a tape measure gives it, is on the wall.
    assert (
        problems_in(tmp_path, with_marker("{id: 2, at: [2, 0.04], height: 1.1, facing: 90}")) == []
    )


def test_a_marker_in_a_doorway_is_reported_as_such(tmp_path):
    problems = problems_in(tmp_path, with_marker("{id: 2, at: [4, 2.1], height: 1.1, facing: 0}"))
    assert problems == ["20: marker 2 at [4.0, 2.1] is in the doorway of door 'a-b': put it "
                        "beside it"]  # fmt: skip


def test_a_marker_not_square_to_its_wall_is_reported_with_the_tolerance(tmp_path):
    slanted = FACING_TOLERANCE_DEG + 1
    problems = problems_in(
        tmp_path, with_marker(f"{{id: 2, at: [2, 0], height: 1.1, facing: {90 + slanted}}}")
    )
    assert problems == [f"20: marker 2 faces {90 + slanted:g}°, {slanted:.1f}° from square to its "
                        "wall: it lies flat on it, facing 90° or 270° (within 2°)"]  # fmt: skip
    nearly = 90 + FACING_TOLERANCE_DEG - 0.5
    marker = f"{{id: 2, at: [2, 0], height: 1.1, facing: {nearly}}}"
    assert problems_in(tmp_path, with_marker(marker)) == []


def test_a_marker_facing_out_of_the_building_is_reported(tmp_path):
    problems = problems_in(tmp_path, with_marker("{id: 2, at: [2, 0], height: 1.1, facing: 270}"))
    assert problems == ["20: marker 2 faces 270°, into no room: turn it round to face 90°, "
                        "into 'a'"]  # fmt: skip


def test_a_marker_overhanging_a_doorway_is_reported(tmp_path):
    # The doorway in x = 4 runs from y = 1.55 to 2.45, its frames 0.08 m either side.
    beside = "{id: 2, at: [4, 1.42], height: 1.1, facing: 180}"
    assert problems_in(tmp_path, with_marker(beside)) == []
    over = "{id: 2, at: [4, 2.45], height: 1.1, facing: 180}"
    assert problems_in(tmp_path, with_marker(over)) == [
        "20: marker 2 at [4.0, 2.45] overhangs the end of its wall (a doorway or a corner): "
        "its 0.16 m square must be on the wall"
    ]


def test_markers_on_the_same_side_of_a_wall_must_not_overlap(tmp_path):
    close = "{id: 2, at: [2.15, 4], height: 1.1, facing: 270}"
    assert problems_in(tmp_path, with_marker(close)) == [
        "20: marker 2 overlaps marker 1: their centres are 0.15 m apart, their papers 0.20 m wide"
    ]
    # Back to back, on the two sides of one wall, they do not.
    text = TWO_ROOMS.replace("[2, 4]", "[4, 3]").replace("facing: 270", "facing: 180")
    text += "    - {id: 2, at: [4, 3], height: 1.1, facing: 0}\n"
    assert problems_in(tmp_path, text) == []


def test_markers_need_walls(tmp_path):
    text = TWO_ROOMS.replace("    outline: [[0, 0], [4, 0], [4, 4], [0, 4]]\n", "")
    text = text.replace("    outline: [[4, 0], [8, 0], [8, 4], [4, 4]]\n", "")
    assert problems_in(tmp_path, text) == [
        "10: markers hang on walls, and this plan has none: give its rooms outlines"
    ]


def test_every_problem_is_reported_at_once(tmp_path):
    text = with_marker("{id: 1, at: [2, 3], height: 9, facing: 0}")
    text += "    - {id: 900, at: [9, 9], height: 1.1, facing: 0}\n"
    problems = problems_in(tmp_path, text)
    assert [problem.split(":")[0] for problem in problems] == ["20", "21", "21"]


def test_the_marker_image_is_what_the_detector_reads():
    square = marker_image("apriltag_36h11", 42, 160)
    page = np.full((240, 240), 255, dtype=np.uint8)
    page[40:200, 40:200] = square
    detector = cv2.aruco.ArucoDetector(aruco_dictionary("apriltag_36h11"))
    corners, ids, _ = detector.detectMarkers(page)
    assert ids is not None and ids.ravel().tolist() == [42]
    assert np.allclose(corners[0][0], [[40, 40], [199, 40], [199, 199], [40, 199]], atol=1)


def test_where_a_marker_goes_is_told_from_the_nearest_doorway_or_corner():
    plan = load_floorplan(EXAMPLE)
    by_id = {marker.id: marker for marker in plan.landmarks.markers}
    place = where_it_goes(plan, Marker(99, (5.2, 12.0), 1.1, 90.0))
    assert str(place) == "room-102, south wall, centre 0.35 m right of the doorway to Main corridor"
    assert place.room.label == "Room 102"
    place = where_it_goes(plan, Marker(99, (6.0, 17.0), 1.1, 270.0))
    assert str(place) == "room-102, north wall, centre 2.00 m from the right-hand corner"
    assert where_it_goes(plan, Marker(99, (6.0, 17.0), 1.1, 0.0)) is None
    assert all(where_it_goes(plan, marker) is not None for marker in by_id.values())


def test_a_surveyed_marker_says_how_well_it_is_known_and_a_loose_one_is_learnt_not_used(
    tmp_path,
):
    text = with_marker("{id: 2, at: [6, 4], height: 1.1, facing: 270, sigma: [0.2, 9]}")
    text = text.replace("      facing: 270\n", "      facing: 270\n      sigma: [0.02, 1.5]\n", 1)
    plan = load_text(tmp_path, text)
    assert plan.landmarks is not None
    sigmas = {marker.id: marker.sigma for marker in plan.landmarks.markers}
    assert sigmas == {1: (0.02, 1.5), 2: (0.2, 9.0)}
    beliefs = marker_beliefs(plan)
    assert beliefs[1].state is MarkerState.KNOWN and beliefs[1].sigma_m == pytest.approx(0.02)
    assert beliefs[2].state is MarkerState.LEARNING
    assert set(marker_poses(plan, known_only=True)) == {1}


def test_a_surveyed_marker_loose_along_its_wall_is_known_across_it_and_used(tmp_path):
    """A survey's sigma is the worst way, along the wall for a marker held to one: across
    it the plan's wall says where it is, so it finds the robot all the same."""
    text = with_marker("{id: 2, at: [6, 4], height: 1.1, facing: 270, sigma: [0.12, 1.5]}")
    belief = marker_beliefs(load_text(tmp_path, text))[2]
    assert belief.state is MarkerState.KNOWN
    # Facing 270 degrees, its wall runs along x.
    assert belief.covariance[0, 0] == pytest.approx(0.12**2)
    assert belief.covariance[1, 1] == pytest.approx(0.02**2)
    assert belief.covariance[0, 1] == pytest.approx(0.0, abs=1e-12)
    assert 2 in marker_poses(load_text(tmp_path, text), known_only=True)


@pytest.mark.parametrize("sigma", ["[0, 1]", "[0.01, 200]", "[0.01]", "0.02", "[a, 1]"])
def test_a_bad_sigma_is_reported_at_its_line(tmp_path, sigma):
    problems = problems_in(tmp_path, with_marker(
        f"{{id: 2, at: [6, 4], height: 1.1, facing: 270, sigma: {sigma}}}"))  # fmt: skip
    assert any(problem.startswith("20:") and "sigma" in problem for problem in problems), problems


def test_markers_written_with_their_sigma_read_back_as_written(tmp_path):
    plan = load_text(tmp_path, TWO_ROOMS)
    assert plan.landmarks is not None
    surveyed = replace(plan.landmarks.markers[0], at=(2.013, 4.0), sigma=(0.021, 1.2))
    written = write_landmarks(plan, replace(plan.landmarks, markers=(surveyed,)))
    assert written.landmarks is not None and written.landmarks.markers == (surveyed,)
    assert "sigma: [0.021, 1.2]" in written.path.read_text()
