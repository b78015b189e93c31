"""Renaming a plan's rooms (issue 16, item 2): in memory, and in the file, as text."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.room_names import RenameError, rename_in_file, renamed
from tests.missions.site import EXAMPLE
from tests.planning.scanned_building import write_scanned_plan

# As `floorplan rooms` writes a plan, in block style, with the operator's own comments.
BLOCK = """\
# The ground floor, from the scan of 3 March.
name: Ground floor
rooms:
  room-1:
    at: [6, 1]   # the corridor
  room-2: {{at: [2, 5]}}
  'room-3':
    at: [6, 5]
  room-4:
    at: [10, 5]
doors:
  - between: [room-1, room-2]
    at: [2, 2.05]
    width: 1.0
  - {{between: [room-1, 'room-3'], at: [6, 2.05], width: 1.0, id: room-1-room-3}}
  - between:
      - room-1
      - room-4
    at: [10, 2.05]
  - {{between: [room-2, room-3], at: [4.05, 5], width: 0.9, id: connecting}}
grid:
  image: {image}
  resolution: {resolution}
  origin: [{origin_x}, {origin_y}, 0.0]
start: room-1  # where the robot charges
"""


def test_the_file_names_the_room_anew_where_it_named_it_and_nothing_else_changes(tmp_path):
    path = write_scanned_plan(tmp_path, BLOCK)
    before = path.read_text()
    plan = rename_in_file(load_floorplan(path), "room-3", "kitchen")
    after = path.read_text()
    assert after == before.replace("'room-3'", "kitchen").replace(
        "room-2, room-3]", "room-2, kitchen]"
    )
    assert "# The ground floor, from the scan of 3 March." in after  # comments kept
    assert set(plan.rooms) == {"room-1", "room-2", "kitchen", "room-4"}
    assert plan.rooms["kitchen"].label == "kitchen" and plan.path == path
    # The door id stays: the simulated building and patrols know it by that id.
    door = next(door for door in plan.doors if door.id == "room-1-room-3")
    assert door.between == ("room-1", "kitchen")
    assert load_floorplan(path).rooms.keys() == plan.rooms.keys()


def test_start_block_lists_and_flow_mappings_are_renamed_too(tmp_path):
    path = write_scanned_plan(tmp_path, BLOCK)
    plan = rename_in_file(load_floorplan(path), "room-1", "corridor")
    assert plan.start == "corridor"
    assert sorted(d.between for d in plan.doors)[:3] == [
        ("corridor", "room-2"),
        ("corridor", "room-3"),
        ("corridor", "room-4"),
    ]
    scanned = write_scanned_plan(tmp_path, name="flow")  # a hand-written, flow-style plan
    plan = rename_in_file(load_floorplan(scanned), "east-room", "lounge")
    assert "lounge: {label: " not in scanned.read_text()  # it had no label: none added
    assert load_floorplan(scanned).rooms["lounge"].at == (10.0, 5.0)


def test_a_name_yaml_would_read_as_a_number_is_quoted(tmp_path):
    path = write_scanned_plan(tmp_path, BLOCK)
    plan = rename_in_file(load_floorplan(path), "room-4", "101")
    assert "101" in plan.rooms and "'101':" in path.read_text()


def test_in_memory_a_renamed_plan_keeps_an_explicit_label(tmp_path):
    plan = load_floorplan(write_scanned_plan(tmp_path))
    corridor = renamed(plan, "corridor", "hall")
    assert corridor.rooms["hall"].label == "Corridor" and corridor.start == "hall"
    assert next(iter(corridor.rooms)) == "hall"  # in its place, not moved to the end
    assert "corridor" not in corridor.rooms and "corridor" in plan.rooms


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        ("pantry", "kitchen", "no room 'pantry'; rooms: corridor, east-room"),
        ("east-room", "the kitchen", "cannot be a room's name"),
        ("east-room", "x" * 65, "cannot be a room's name"),
        ("east-room", "west-room", "there is a room 'west-room' already"),
        ("east-room", "connecting", "there is a door 'connecting'"),
    ],
)
def test_a_rename_that_cannot_be_says_why_and_leaves_the_file(tmp_path, old, new, says):
    path = write_scanned_plan(tmp_path)
    before = path.read_text()
    with pytest.raises(RenameError, match=says.replace("'", ".")):
        rename_in_file(load_floorplan(path), old, new)
    assert path.read_text() == before
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_file_edited_since_it_was_read_is_not_overwritten(tmp_path):
    path = write_scanned_plan(tmp_path)
    plan = load_floorplan(path)
    path.write_text(path.read_text().replace("east-room", "lounge"))
    with pytest.raises(RenameError, match="does not name room 'east-room'"):
        rename_in_file(plan, "east-room", "kitchen")
    assert "lounge" in path.read_text()


def test_the_example_that_ships_with_the_console_is_not_renamed():
    before = EXAMPLE.read_text()
    with pytest.raises(RenameError, match="example that comes with the console"):
        rename_in_file(load_floorplan(EXAMPLE), "kitchen", "cookhouse")
    assert EXAMPLE.read_text() == before


def test_a_disk_that_fails_the_write_leaves_the_file_and_no_litter(tmp_path, monkeypatch):
    path = write_scanned_plan(tmp_path)
    before = path.read_text()

    def full(*args):  # as a full disk or a read-only folder fails the last step
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(OSError, match="No space"):
        rename_in_file(load_floorplan(path), "east-room", "kitchen")
    assert path.read_text() == before
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_the_file_keeps_its_permissions(tmp_path):
    path = write_scanned_plan(tmp_path)
    path.chmod(0o640)
    rename_in_file(load_floorplan(path), "east-room", "kitchen")
    assert Path(path).stat().st_mode & 0o777 == 0o640


def test_the_room_a_robot_stands_in_is_the_one_in_sight_not_the_nearest_through_a_wall(tmp_path):
    from giraff_console.planning.route_planner import RoutePlanner, walls_of

    plan = load_floorplan(write_scanned_plan(tmp_path))
    planner = RoutePlanner(plan, walls_of(plan))
    # At the corridor's west end, beside a wall of west-room, whose point is 4.2 m away
    # through the wall: the corridor's point (6, 1) is further, 5.2 m, but in sight.
    assert planner.room_at((0.8, 1.0)) == "corridor"
    assert planner.room_at((9.0, 5.0)) == "east-room"


def test_doors_named_by_their_rooms_keep_their_ids_in_both_styles(tmp_path):
    path = write_scanned_plan(tmp_path, BLOCK)
    before = {door.id for door in load_floorplan(path).doors}
    plan = rename_in_file(load_floorplan(path), "room-1", "corridor")
    assert {door.id for door in plan.doors} == before  # room-1-room-2 and room-1-room-4
    text = path.read_text()
    assert "    width: 1.0\n    id: room-1-room-2\n  - {between: [corridor, 'room-3']" in text
    assert "      - room-4\n    at: [10, 2.05]\n    id: room-1-room-4\n" in text
    flow = write_scanned_plan(tmp_path, name="flow")
    ids = {door.id for door in load_floorplan(flow).doors}
    renamed_flow = rename_in_file(load_floorplan(flow), "corridor", "hall")
    assert {door.id for door in renamed_flow.doors} == ids
    assert "width: 1.0, id: corridor-east-room}" in flow.read_text()


def test_a_door_with_a_comment_on_its_last_line_gets_its_id_below_the_comment(tmp_path):
    text = BLOCK.replace("      - room-4\n    at: [10, 2.05]\n",
                         "      - room-4\n    at: [10, 2.05]  # the east doorway\n")  # fmt: skip
    path = write_scanned_plan(tmp_path, text)
    rename_in_file(load_floorplan(path), "room-4", "lounge")
    assert "at: [10, 2.05]  # the east doorway\n    id: room-1-room-4\n" in path.read_text()


def test_windows_line_endings_are_kept(tmp_path):
    path = write_scanned_plan(tmp_path, BLOCK)
    path.write_bytes(path.read_bytes().replace(b"\n", b"\r\n"))
    rename_in_file(load_floorplan(path), "room-4", "lounge")
    data = path.read_bytes()
    assert b"lounge:\r\n" in data and b"\n" not in data.replace(b"\r\n", b"")


def test_a_plan_with_anchors_is_refused_by_name_and_left(tmp_path):
    text = BLOCK.replace("room-2: {{at: [2, 5]}}", "room-2: {{at: &west [2, 5]}}")
    path = write_scanned_plan(tmp_path, text)
    before = path.read_text()
    with pytest.raises(RenameError, match="uses YAML anchors"):
        rename_in_file(load_floorplan(path), "room-4", "lounge")
    assert path.read_text() == before


def test_a_plan_reached_through_a_link_is_renamed_where_it_is_and_the_link_stays(tmp_path):
    real = write_scanned_plan(tmp_path)
    link = tmp_path / "home.yaml"
    link.symlink_to(real)
    plan = rename_in_file(load_floorplan(link), "east-room", "kitchen")
    assert link.is_symlink() and plan.path == link
    assert "kitchen" in load_floorplan(real).rooms


def test_a_robot_against_a_wall_still_sees_its_own_room(tmp_path):
    from giraff_console.planning.route_planner import RoutePlanner, walls_of

    plan = load_floorplan(write_scanned_plan(tmp_path))
    planner = RoutePlanner(plan, walls_of(plan))
    # In middle-room, 0.2 m from its south wall (inside the robot's inflation, where
    # the inflated grid sees nothing): the corridor's point (6, 1) is nearer, but
    # through the wall; middle-room's (6, 5) is in sight.
    assert planner.room_at((5.0, 2.3)) == "middle-room"
    assert planner.room_at((4.6, 2.3)) == "middle-room"
