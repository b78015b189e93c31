"""`giraff-console floorplan landmarks`: markers placed for the user beside every doorway
and along long walls, written into the plan without losing anything else in it."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

from giraff_console.camera.marker_reach import STANDARD_SIZE_M
from giraff_console.cli.main import main
from giraff_console.planning import landmark_placement
from giraff_console.planning.floorplan import (
    FloorPlanError,
    Marker,
    check_floorplan,
    load_floorplan,
)
from giraff_console.planning.landmark_placement import (
    BESIDE_DOOR_M,
    DEFAULT_HEIGHT_M,
    place_markers,
    with_landmarks,
    write_landmarks,
)
from giraff_console.planning.landmarks import (
    WALL_TOLERANCE_M,
    fit_on_walls,
    marker_walls,
    room_in_front,
)

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "giraff_console/floorplans"
FIXTURES = Path(__file__).parent / "fixtures"


def bare_example(folder: Path) -> Path:
    """The example care home without its markers, beside its grid image."""
    text = (EXAMPLES / "care-home.yaml").read_text()
    head, _, _ = text.partition("\nlandmarks:\n")
    shutil.copy(EXAMPLES / "care-home.pgm", folder / "care-home.pgm")
    path = folder / "care-home.yaml"
    path.write_text(head + "\n")
    assert load_floorplan(path).landmarks is None
    return path


def small_home(folder: Path) -> Path:
    for name in ("small-home.yaml", "small-home.pgm"):
        shutil.copy(FIXTURES / name, folder / name)
    return folder / "small-home.yaml"


def doorway_markers(plan, markers):
    """For each door and each of its rooms, the markers beside it facing into that room."""
    return {
        (door.id, room): [
            marker
            for marker in markers
            if math.dist(marker.at, door.at) <= BESIDE_DOOR_M + door.width / 2
            and getattr(room_in_front(plan, marker.at, marker.facing), "id", None) == room
        ]
        for door in plan.doors
        for room in door.between
    }


@pytest.mark.parametrize("maker", [bare_example, small_home])
def test_every_doorway_gets_a_marker_in_each_of_its_rooms(tmp_path, maker):
    plan = load_floorplan(maker(tmp_path))
    placement = place_markers(plan)
    beside = doorway_markers(plan, placement.landmarks.markers)
    assert all(beside.values()), [key for key, found in beside.items() if not found]
    assert placement.notes == []


def test_placed_markers_have_unique_ids_and_sit_square_on_walls(tmp_path):
    plan = load_floorplan(bare_example(tmp_path))
    landmarks = place_markers(plan).landmarks
    assert (landmarks.family, landmarks.size) == ("apriltag_36h11", STANDARD_SIZE_M)
    ids = [marker.id for marker in landmarks.markers]
    assert ids == list(range(len(ids)))
    walls = marker_walls(plan)
    for marker in landmarks.markers:
        fit = fit_on_walls(marker.at, marker.facing, walls)
        assert fit.wall is not None and fit.distance <= WALL_TOLERANCE_M, marker
        assert marker.height == DEFAULT_HEIGHT_M
        assert room_in_front(plan, marker.at, marker.facing) is not None


def test_long_walls_get_markers_every_few_metres(tmp_path):
    plan = load_floorplan(bare_example(tmp_path))
    # The north corridor's south wall: 32 m, with no doorway in it.
    on_it = [
        marker.at[0]
        for marker in place_markers(plan, every=4.0).landmarks.markers
        if marker.at[1] == 17.0 and marker.facing == 90.0
    ]
    gaps = [b - a for a, b in zip([0.0, *sorted(on_it)], [*sorted(on_it), 32.0], strict=True)]
    assert max(gaps[1:-1]) <= 1.25 * 4.0 and gaps[0] <= 4.0 and gaps[-1] <= 4.0
    sparse = place_markers(plan, every=8.0)
    assert sparse.along_walls < place_markers(plan, every=4.0).along_walls
    # Rooms of 4 m by 5 m: no wall is 6 m long, so none gets markers along it; only one
    # for its stop, which reads just the marker beside its door (stop_markers.py).
    placement = place_markers(plan, every=6.0)
    markers = placement.landmarks.markers
    for_stops = markers[len(markers) - placement.for_stops :]
    in_rooms = [
        m for m in markers
        if getattr(room_in_front(plan, m.at, m.facing), "id", "")[:5] == "room-"
        and not any(math.dist(m.at, door.at) < 1.5 for door in plan.doors)
    ]  # fmt: skip
    assert in_rooms and set(in_rooms) <= set(for_stops)


def test_the_plan_round_trips_through_the_file(tmp_path):
    path = bare_example(tmp_path)
    before = path.read_text()
    plan = load_floorplan(path)
    placement = place_markers(plan)
    written = write_landmarks(plan, placement.landmarks)
    assert written.landmarks == placement.landmarks
    assert load_floorplan(path).landmarks == placement.landmarks
    assert (written.rooms, written.doors, written.start) == (plan.rooms, plan.doors, plan.start)
    after = path.read_text()
    # Everything the user wrote, comments included, is still there as it was.
    assert after.startswith(before) and "# An example care home" in after
    assert check_floorplan(path) == []
    # No temporary file is left beside it.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["care-home.pgm", "care-home.yaml"]


def test_placing_again_keeps_what_is_there_and_adds_nothing(tmp_path):
    path = bare_example(tmp_path)
    plan = load_floorplan(path)
    write_landmarks(plan, place_markers(plan).landmarks)
    again = place_markers(load_floorplan(path))
    assert again.added == 0
    assert again.landmarks == load_floorplan(path).landmarks


def test_hand_placed_markers_stay_and_new_ids_follow_theirs(tmp_path):
    path = small_home(tmp_path)
    text = path.read_text() + (
        "landmarks:\n  family: apriltag_36h11\n  size: 0.2\n  markers:\n"
        "    - {id: 40, at: [7.5, 0], height: 1.5, facing: 90}  # by hand\n"
    )
    path.write_text(text)
    plan = load_floorplan(path)
    placement = place_markers(plan)
    assert placement.landmarks.size == 0.2
    assert Marker(40, (7.5, 0.0), 1.5, 90.0) in placement.landmarks.markers
    assert sorted(m.id for m in placement.landmarks.markers)[1:] == list(
        range(41, 40 + len(placement.landmarks.markers))
    )


def test_the_landmarks_block_is_replaced_where_it_is_and_comments_after_it_stay(tmp_path):
    text = (
        "name: x  # the name\nlandmarks:\n  family: apriltag_36h11\n  size: 0.16\n"
        "  markers:\n  - {id: 1, at: [0, 0], height: 1, facing: 0}  # old\n\n"
        "# About the rooms.\nrooms: {a: {at: [0, 0]}}\n"
    )
    new = with_landmarks(text, "landmarks: NEW\n")
    assert (
        new
        == "name: x  # the name\nlandmarks: NEW\n\n# About the rooms.\nrooms: {a: {at: [0, 0]}}\n"
    )
    assert with_landmarks("name: x", "landmarks: NEW\n") == "name: x\n\nlandmarks: NEW\n"
    with pytest.raises(ValueError, match="block mapping"):
        with_landmarks("{name: x, rooms: {}}\n", "landmarks: NEW\n")


def test_accents_before_the_block_and_windows_line_ends_are_kept(tmp_path):
    path = small_home(tmp_path)
    text = "# Küche, Flur — °\r\n" + path.read_text().replace("\n", "\r\n")
    path.write_bytes(text.encode())
    plan = load_floorplan(path)
    write_landmarks(plan, place_markers(plan).landmarks)
    data = path.read_bytes()
    assert data.startswith(text.encode()) and b"\nlandmarks:" in data
    assert data.count(b"\n") == data.count(b"\r\n")
    written = load_floorplan(path)
    write_landmarks(written, place_markers(written, every=2.0).landmarks)
    assert path.read_bytes().startswith(text.encode())
    assert len(load_floorplan(path).landmarks.markers) > len(written.landmarks.markers)


def test_a_symbolic_link_is_refused_rather_than_replaced(tmp_path):
    link = tmp_path / "link.yaml"
    link.symlink_to(small_home(tmp_path))
    plan = load_floorplan(link)
    with pytest.raises(ValueError, match="symbolic link"):
        write_landmarks(plan, place_markers(plan).landmarks)
    assert link.is_symlink()


def test_a_file_that_would_not_check_is_never_written(tmp_path, monkeypatch):
    path = bare_example(tmp_path)
    before = path.read_text()
    plan = load_floorplan(path)
    placement = place_markers(plan)
    monkeypatch.setattr(
        landmark_placement, "landmarks_block", lambda plan, landmarks: "landmarks: 12\n"
    )
    with pytest.raises(FloorPlanError) as caught:
        write_landmarks(plan, placement.landmarks)
    assert str(caught.value).startswith(f"{path}:")
    assert path.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["care-home.pgm", "care-home.yaml"]


def test_a_plan_with_neither_outlines_nor_a_grid_has_no_walls_for_markers(tmp_path):
    # Without outlines the walls are the grid's (tests/planning/test_grid_markers.py).
    path = tmp_path / "plan.yaml"
    path.write_text("name: x\nrooms:\n  a: {at: [0, 0]}\n  b: {at: [2, 0]}\n"
                    "doors:\n  - {between: [a, b], at: [1, 0]}\n")  # fmt: skip
    with pytest.raises(ValueError, match="no room has an outline, and there is no grid"):
        place_markers(load_floorplan(path))
    assert main(["floorplan", "landmarks", str(path)]) == 2


def test_the_command_places_writes_and_says_how_many(tmp_path, capsys):
    path = bare_example(tmp_path)
    assert main(["floorplan", "landmarks", str(path)]) == 0
    out = capsys.readouterr().out
    count = len(load_floorplan(path).landmarks.markers)
    assert out.startswith(f"{path}: placed {count} markers (")
    assert main(["floorplan", "check", str(path)]) == 0
    assert main(["floorplan", "landmarks", "--every", "4", str(path)]) == 0
    assert (
        f"placed 0 markers (0 beside doorways, 0 along walls, 0 for rooms' stops); it has "
        f"{count} in all, 0.16 m across" in capsys.readouterr().out
    )


def test_the_command_refuses_a_bad_plan_and_a_bad_spacing(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nrooms: {}\n")
    assert main(["floorplan", "landmarks", str(path)]) == 2
    assert f"{path}:2:" in capsys.readouterr().err
    good = bare_example(tmp_path)
    before = good.read_text()
    for every in ("0", "-1", "nan"):
        assert main(["floorplan", "landmarks", "--every", every, str(good)]) == 2
        assert "--every must be positive" in capsys.readouterr().err
    assert good.read_text() == before
    with pytest.raises(SystemExit):
        main(["floorplan", "landmarks", "--every", "3", "--print", str(tmp_path), str(good)])


def test_the_example_care_home_is_as_the_command_leaves_it():
    plan = load_floorplan(EXAMPLES / "care-home.yaml")
    assert place_markers(plan).added == 0
    beside = doorway_markers(plan, plan.landmarks.markers)
    assert all(beside.values())
