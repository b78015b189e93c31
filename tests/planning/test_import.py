"""Floor plans imported from Open-RMF building maps, with ROS maps as their grids."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
from giraff_console.planning.rmf_import import read_building, sanitise_id
from giraff_console.planning.room_graph import RoomGraph
from giraff_console.planning.ros_map import read_ros_map

SMALL = Path(__file__).parent / "fixtures" / "small.building.yaml"
# The fixture's two measurements: 500 px are 10 m, 300 px are 6.3 m; RMF takes the mean.
SCALE = (10 / 500 + 6.3 / 300) / 2

TWO_ROOMS = """\
coordinate_system: cartesian_meters
levels:
  L1:
    vertices:
      - [1.5, 2.0, 0, a]
      - [4.5, 2.0, 0, b]
    lanes:
      - [0, 1, {graph_idx: [2, 0]}]
"""


def metres(x: float, y: float) -> tuple[float, float]:
    """A pixel of the fixture's drawing in the map frame: scaled, and y flipped, since
    pixel rows grow downwards."""
    return (x * SCALE, -y * SCALE)


def write(tmp_path: Path, text: str, name: str = "b.building.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def ros_map(tmp_path: Path, text: str | None = None) -> Path:
    """A 11 m x 10 m ROS map whose lower-left corner is at (0, -10): free inside a
    one-pixel wall, so that every room of the fixture is on a free cell."""
    pixels = np.full((100, 110), 254, np.uint8)
    pixels[[0, -1], :] = pixels[:, [0, -1]] = 0
    cv2.imwrite(str(tmp_path / "map.pgm"), pixels)
    text = text or (
        "image: map.pgm\nresolution: 0.1\norigin: [0.0, -10.0, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return write(tmp_path, text, "map.yaml")


def door(plan: dict, door_id: str) -> dict:
    (found,) = [door for door in plan["doors"] if door["id"] == door_id]
    return found


def test_named_vertices_become_rooms_at_their_positions_in_metres():
    rooms = read_building(SMALL).plan["rooms"]
    assert list(rooms) == ["dock", "hall", "Office-1", "kitchen", "lounge"]
    pixels = {"dock": (60, 400), "hall": (260, 400), "Office-1": (260, 160),
              "kitchen": (460, 400), "lounge": (460, 160)}  # fmt: skip
    for room_id, (x, y) in pixels.items():
        assert tuple(rooms[room_id]["at"]) == pytest.approx(metres(x, y), abs=1e-3)


def test_a_name_that_is_not_an_id_is_made_one_and_kept_as_the_label():
    rooms = read_building(SMALL).plan["rooms"]
    assert rooms["Office-1"]["label"] == "Office 1"
    assert "label" not in rooms["hall"]


def test_an_rmf_door_across_a_lane_keeps_its_name_centre_and_width():
    dock_door = door(read_building(SMALL).plan, "dock-door")
    assert dock_door["between"] == ["dock", "hall"]
    # The door runs from (210, 360) to (210, 440) in pixels.
    assert tuple(dock_door["at"]) == pytest.approx(metres(210, 400), abs=1e-3)
    assert dock_door["width"] == pytest.approx(80 * SCALE, abs=1e-3)


def test_a_chain_through_unnamed_vertices_gets_a_door_halfway_along_it():
    # Office 1 (260, 160) -> (260, 60) -> (460, 60) -> lounge (460, 160): 400 px long,
    # so halfway is 200 px along, the middle of the top lane.
    office_lounge = door(read_building(SMALL).plan, "Office-1-lounge")
    assert office_lounge["between"] == ["Office-1", "lounge"]
    assert tuple(office_lounge["at"]) == pytest.approx(metres(360, 60), abs=1e-3)
    assert "width" not in office_lounge  # the floor plan's default


def test_a_lane_between_two_rooms_gets_a_door_at_its_middle():
    hall_kitchen = door(read_building(SMALL).plan, "hall-kitchen")
    assert tuple(hall_kitchen["at"]) == pytest.approx(metres(360, 400), abs=1e-3)


def test_every_pair_of_rooms_joined_by_lanes_gets_exactly_one_door():
    pairs = [tuple(door["between"]) for door in read_building(SMALL).plan["doors"]]
    assert sorted(pairs) == sorted([("dock", "hall"), ("hall", "Office-1"), ("hall", "kitchen"),
                                    ("Office-1", "lounge"), ("kitchen", "lounge")])  # fmt: skip


def test_cartesian_metres_are_taken_as_they_are(tmp_path):
    plan = read_building(write(tmp_path, TWO_ROOMS)).plan
    assert plan["rooms"] == {"a": {"at": [1.5, 2.0]}, "b": {"at": [4.5, 2.0]}}
    assert plan["doors"] == [{"between": ["a", "b"], "at": [3.0, 2.0], "id": "a-b"}]


def test_the_imported_plan_loads_and_routes_through_the_rmf_door(tmp_path):
    out = tmp_path / "small.yaml"
    assert main(["floorplan", "import", str(SMALL), str(out)]) == 0
    route = RoomGraph(load_floorplan(out)).route("dock", "lounge")
    # Through the kitchen: 440 px against 523 px through Office 1.
    assert route.rooms == ["dock", "hall", "kitchen", "lounge"]
    assert route.doors == ["dock-door", "hall-kitchen", "kitchen-lounge"]


def test_import_prints_the_rooms_and_doors_it_wrote(tmp_path, capsys):
    out = tmp_path / "small.yaml"
    assert main(["floorplan", "import", str(SMALL), str(out), "--name", "Small"]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out}: 5 rooms (dock, hall, Office-1, kitchen, lounge), 5 doors" in printed
    assert load_floorplan(out).name == "Small"


def test_a_ros_map_becomes_the_grid_with_its_image_copied_next_to_the_plan(tmp_path):
    out_dir = tmp_path / "plans"
    out_dir.mkdir()
    args = ["floorplan", "import", str(SMALL), str(out_dir / "small.yaml")]
    assert main([*args, "--grid", str(ros_map(tmp_path))]) == 0
    plan = load_floorplan(out_dir / "small.yaml")
    assert plan.grid is not None
    assert plan.grid.image == out_dir / "small.pgm"
    assert plan.grid.image.read_bytes() == (tmp_path / "map.pgm").read_bytes()
    assert (plan.grid.resolution, plan.grid.origin) == (0.1, (0.0, -10.0, 0.0))


def test_a_ros_map_is_read_with_its_image_relative_to_its_yaml(tmp_path):
    grid = read_ros_map(ros_map(tmp_path))
    assert grid.image == tmp_path / "map.pgm"
    assert (grid.negate, grid.occupied_thresh, grid.free_thresh) == (0, 0.65, 0.196)


def test_an_existing_output_is_kept_unless_forced(tmp_path, capsys):
    out = write(tmp_path, "keep me\n", "small.yaml")
    assert main(["floorplan", "import", str(SMALL), str(out)]) == 2
    assert f"{out} exists: --force overwrites it" in capsys.readouterr().err
    assert out.read_text() == "keep me\n"
    assert main(["floorplan", "import", str(SMALL), str(out), "--force"]) == 0
    assert "dock-door" in out.read_text()


def test_a_room_nothing_leads_to_is_left_out_with_a_note_at_its_line(tmp_path, capsys):
    # Changed (issue 16): a real map is imported as it is; this was an error, and nothing
    # was written.
    lonely = TWO_ROOMS.replace("    lanes:", "      - [9.0, 9.0, 0, c]\n    lanes:")
    out = tmp_path / "plan.yaml"
    source = write(tmp_path, lonely)
    assert main(["floorplan", "import", str(source), str(out)]) == 0
    err = capsys.readouterr().err
    assert f"{source}:7: note: vertex 2 ('c') is cut off from the rest of the level" in err
    assert list(load_floorplan(out).rooms) == ["a", "b"]


def test_a_room_off_the_grid_is_reported_and_neither_file_is_written(tmp_path, capsys):
    grid = ros_map(tmp_path)
    grid.write_text(grid.read_text().replace("origin: [0.0, -10.0, 0.0]", "origin: [50, 50, 0]"))
    out = tmp_path / "plan.yaml"
    assert main(["floorplan", "import", str(SMALL), str(out), "--grid", str(grid)]) == 2
    # At the line of the vertex the room was made from, as every problem of an import is.
    line = next(i for i, text in enumerate(SMALL.read_text().splitlines(), 1) if " dock, " in text)
    err = capsys.readouterr().err
    assert f"{SMALL}:{line}: room 'dock' at [1.23, -8.2] is off the grid" in err
    assert not out.exists() and not (tmp_path / "plan.pgm").exists()


def test_an_rmf_door_across_no_lane_between_rooms_is_left_out_with_a_note(tmp_path, capsys):
    # The door stands at x = 9, beyond the lane from a to b.
    door_far_off = (
        "      - [9, 0, 0, '']\n      - [9, 1, 0, '']\n    doors: [[2, 3, {name: [1, x]}]]"
    )
    source = write(tmp_path, TWO_ROOMS.replace("    lanes:", f"{door_far_off}\n    lanes:"))
    assert main(["floorplan", "import", str(source), str(tmp_path / "p.yaml")]) == 0
    assert f"{source}:9: note: door 'x' crosses no lane: left out" in capsys.readouterr().err


def test_a_missing_source_exits_2_with_a_message(tmp_path, capsys):
    missing = tmp_path / "nowhere.building.yaml"
    assert main(["floorplan", "import", str(missing), str(tmp_path / "p.yaml")]) == 2
    assert f"{missing}: cannot read it" in capsys.readouterr().err


def test_a_source_that_is_not_yaml_is_reported_at_its_line(tmp_path, capsys):
    source = write(tmp_path, "levels:\n  L1: [unclosed\n  L2: {}\n")
    assert main(["floorplan", "import", str(source), str(tmp_path / "p.yaml")]) == 2
    assert f"{source}:3: not YAML" in capsys.readouterr().err


def test_several_levels_without_a_choice_are_listed(tmp_path, capsys):
    source = write(tmp_path, TWO_ROOMS + "  L2:\n    vertices: [[0, 0, 0, c]]\n")
    assert main(["floorplan", "import", str(source), str(tmp_path / "p.yaml")]) == 2
    assert f"{source}:2: several levels (L1, L2): choose one" in capsys.readouterr().err


def test_level_chooses_one_of_several_levels(tmp_path):
    source = write(tmp_path, TWO_ROOMS + "  L2:\n    vertices: [[0, 0, 0, c]]\n")
    assert list(read_building(source, level="L2").plan["rooms"]) == ["c"]


def test_an_unknown_level_is_reported_with_the_levels_there_are(tmp_path, capsys):
    args = ["floorplan", "import", str(SMALL), str(tmp_path / "p.yaml"), "--level", "L9"]
    assert main(args) == 2
    assert "no level called 'L9' (levels: L1)" in capsys.readouterr().err


def test_two_vertices_making_the_same_room_id_are_numbered_with_a_note(tmp_path):
    # Changed (issue 16): this was an error asking for one of them to be renamed.
    source = write(tmp_path, TWO_ROOMS.replace("0, b]", "0, 'a!']"))
    imported = read_building(source)
    assert imported.plan["rooms"] == {"a": {"at": [1.5, 2.0]},
                                      "a-2": {"label": "a!", "at": [4.5, 2.0]}}  # fmt: skip
    assert imported.notes == [
        f"{source}:6: note: vertex 1 ('a!') would be room 'a', as vertex 0 ('a', line 5) "
        "is: it is room 'a-2'"
    ]


def test_a_lane_to_a_missing_vertex_is_reported_at_its_line(tmp_path):
    source = write(tmp_path, TWO_ROOMS.replace("[0, 1, {graph_idx", "[0, 7, {graph_idx"))
    with pytest.raises(FloorPlanError, match=r":8: levels\.L1\.lanes\[0\] should be .* 0 to 1"):
        read_building(source)


def test_a_level_in_pixels_without_measurements_is_refused(tmp_path):
    source = write(tmp_path, TWO_ROOMS.replace("cartesian_meters", "reference_image"))
    with pytest.raises(FloorPlanError, match=r"levels\.L1 has no measurements"):
        read_building(source)


def test_lanes_crossing_two_doors_make_the_space_between_them_a_room(tmp_path):
    # Changed (issue 16): this was an error asking for a vertex between the doors.
    text = TWO_ROOMS.replace("    lanes:", "\n".join([
        "      - [2, 1, 0, '']", "      - [2, 3, 0, '']", "      - [4, 1, 0, '']",
        "      - [4, 3, 0, '']", "    doors:", "      - [2, 3, {name: [1, d1]}]",
        "      - [4, 5, {name: [1, d2]}]", "    lanes:",
    ]))  # fmt: skip
    source = write(tmp_path, text)
    imported = read_building(source)
    assert imported.plan["rooms"]["space-1"] == {"at": [3.0, 2.0]}
    assert [door["between"] for door in imported.plan["doors"]] == [["a", "space-1"],
                                                                    ["b", "space-1"]]  # fmt: skip
    assert imported.notes == [f"{source}:12: note: door 'd1' leads to a space with no named "
                              "vertex: it is room 'space-1', at [3.0, 2.0]"]  # fmt: skip


def test_a_door_before_a_junction_joins_the_nearest_room_beyond_it(tmp_path):
    # Changed (issue 16): this was an error asking for the junction to be named. a, b and
    # c meet at an unnamed junction; the door crosses a's lane to it.
    text = """\
coordinate_system: cartesian_meters
levels:
  L1:
    vertices:
      - [0, 0, 0, a]
      - [4, 0, 0, b]
      - [2, 3, 0, c]
      - [2, 0, 0, '']
      - [1, -1, 0, '']
      - [1, 1, 0, '']
    lanes: [[0, 3, {}], [3, 1, {}], [3, 2, {}]]
    doors: [[4, 5, {name: [1, front]}]]
"""
    plan = read_building(write(tmp_path, text)).plan
    assert plan["doors"] == [
        {"between": ["a", "b"], "at": [1.0, 0.0], "width": 2.0, "id": "front"},
        # Halfway along the lanes from b to c, through the junction: 2 m, then 0.5 m up.
        {"between": ["b", "c"], "at": [2.0, 0.5], "id": "b-c"},
    ]


def test_a_ros_map_with_a_missing_image_exits_2(tmp_path, capsys):
    grid = ros_map(tmp_path)
    grid.write_text(grid.read_text().replace("map.pgm", "gone.pgm"))
    args = ["floorplan", "import", str(SMALL), str(tmp_path / "p.yaml"), "--grid", str(grid)]
    assert main(args) == 2
    assert f"{grid}:1: image 'gone.pgm' is missing" in capsys.readouterr().err


@pytest.mark.parametrize("resolution", ["-0.05", "0", "fine", ".nan"])
def test_a_ros_map_with_a_bad_resolution_exits_2(tmp_path, capsys, resolution):
    grid = ros_map(tmp_path)
    grid.write_text(grid.read_text().replace("resolution: 0.1", f"resolution: {resolution}"))
    args = ["floorplan", "import", str(SMALL), str(tmp_path / "p.yaml"), "--grid", str(grid)]
    assert main(args) == 2
    assert f"{grid}:2: resolution should be metres per pixel, above 0" in capsys.readouterr().err


def test_a_ros_map_without_a_key_map_server_needs_is_refused(tmp_path):
    grid = ros_map(tmp_path)
    grid.write_text(grid.read_text().replace("negate: 0\n", ""))
    with pytest.raises(FloorPlanError, match="missing key negate"):
        read_ros_map(grid)


def test_a_ros_map_in_raw_mode_is_refused(tmp_path):
    grid = ros_map(tmp_path)
    grid.write_text(grid.read_text() + "mode: raw\n")
    with pytest.raises(FloorPlanError, match=":7: mode raw is not supported"):
        read_ros_map(grid)


@pytest.mark.parametrize(
    ("name", "expected"),
    [("Room 101", "Room-101"), ("tinyRobot1_charger", "tinyRobot1_charger"),
     ("  lounge (east) ", "lounge-east"), ("x" * 70, "x" * 64), ("!!!", "")],
)  # fmt: skip
def test_names_are_made_ids_of_letters_digits_dashes_and_underscores(name, expected):
    assert sanitise_id(name) == expected


def test_two_named_vertices_at_one_point_are_told(tmp_path):
    same = "      - [1.5, 2.0, 0, c]\n    lanes:"
    source = write(tmp_path, TWO_ROOMS.replace("    lanes:", same))
    assert (
        f"{source}:7: note: vertex 2 ('c') is where vertex 0 ('a') is: rooms 'a' and 'c' "
        "are one place, and a passage between them is there" in read_building(source).notes
    )


def test_a_second_door_named_like_a_room_is_told_in_the_names_the_map_gave(tmp_path):
    doors = (
        "      - [3, 1, 0, '']\n      - [3, 3, 0, '']\n      - [3.5, 1, 0, '']\n"
        "      - [3.5, 3, 0, '']\n    doors: [[2, 3, {name: [1, a]}], [4, 5, {name: [1, a]}]]"
    )
    source = write(tmp_path, TWO_ROOMS.replace("    lanes:", f"{doors}\n    lanes:"))
    notes = read_building(source).notes
    assert f"{source}:11: note: door 'a' has the name of a room: it is door 'a-door'" in notes
    assert f"{source}:11: note: door 'a' has the name of a room and the name of another door " \
           "(line 11): it is door 'a-door-2'" in notes  # fmt: skip


def refused(tmp_path: Path, text: str) -> tuple[Path, FloorPlanError]:
    """A building map of `text` written, and the error importing it raises."""
    source = write(tmp_path, text)
    with pytest.raises(FloorPlanError) as error:
        read_building(source)
    return source, error.value


def test_a_level_whose_named_vertices_are_all_left_out_says_so(tmp_path):
    walled = (
        "coordinate_system: cartesian_meters\nlevels:\n  L1:\n    vertices:\n"
        "      - [0, 0, 0, '']\n      - [4, 0, 0, '']\n      - [4, 4, 0, '']\n"
        "      - [0, 4, 0, '']\n      - [90, 90, 0, far]\n"
        "    walls: [[0, 1, {}], [1, 2, {}], [2, 3, {}], [3, 0, {}]]\n"
    )
    source, error = refused(tmp_path, walled)
    assert f"{source}:3: levels.L1 has no rooms: each of its named vertices was left out " \
           "(the notes above say why)" in str(error)  # fmt: skip


def test_a_pixel_map_with_a_bad_measurement_has_every_problem_told_in_line_order(tmp_path):
    # The scale is worked out before the lanes and walls are read: a bad measurement is
    # one problem of them all, not the only one.
    bad = (
        "coordinate_system: reference_image\nlevels:\n  L1:\n"
        "    lanes:\n      - [0, 5, {graph_idx: [2, 0]}]\n"
        "    measurements:\n      - [0, 0, {distance: [3, 5]}]\n"
        "    vertices:\n      - [0, 0, 0, a]\n      - [100, 0, 0, b]\n"
        "    walls:\n      - [0, 9]\n"
    )
    _, error = refused(tmp_path, bad)
    assert [problem.line for problem in error.problems] == [5, 7, 12], str(error)
