"""Markers that every room's stop can read (planning/stop_markers.py): a stop far from
every wall gets markers large enough, or the plan is told it cannot have them."""

from __future__ import annotations

import math

from giraff_console.camera.marker_reach import STANDARD_SIZE_M, read_reach
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.landmark_placement import place_markers
from giraff_console.planning.landmarks import marker_walls
from giraff_console.planning.marker_sight import visible_markers
from giraff_console.planning.stop_markers import LARGEST_SIZE_M, reads
from giraff_console.robot.ekf import marker_pose
from giraff_console.robot.odometry import Pose


def hall_plan(tmp_path, hall_side: float = 12.0):
    """A small room and, through a door, a square hall whose stop is in its middle,
    hall_side / 2 from every wall."""
    side, east = hall_side, 4 + hall_side
    outline = f"[[4, 0], [{east}, 0], [{east}, {side}], [4, {side}]]"
    text = f"""name: hall
rooms:
  office: {{at: [2, 2], outline: [[0, 0], [4, 0], [4, 4], [0, 4]]}}
  hall: {{at: [{4 + side / 2}, {side / 2}], outline: {outline}}}
doors:
- {{between: [office, hall], at: [4, 2], width: 0.9}}
start: office
"""
    path = tmp_path / "hall.yaml"
    path.write_text(text)
    return load_floorplan(path)


def poses_of(markers) -> dict[int, Pose]:
    return {marker.id: marker_pose(marker) for marker in markers}


def every_stop_reads(plan, landmarks) -> bool:
    poses, sight = poses_of(landmarks.markers), marker_walls(plan).segments
    return all(reads(room.at, poses, sight, landmarks.size) for room in plan.rooms.values())


def test_a_hall_gets_markers_large_enough_to_be_read_from_its_middle(tmp_path):
    plan = hall_plan(tmp_path, 12.0)
    placement = place_markers(plan)
    size = placement.landmarks.size
    # 6 m from every wall: a 16 cm marker is read to 4 m, a 24 cm one to 6 m.
    assert STANDARD_SIZE_M < size <= LARGEST_SIZE_M
    assert read_reach(size) >= 6.0 > read_reach(size - 0.01)
    assert any("so that every room's stop can read them" in note for note in placement.notes)
    assert every_stop_reads(plan, placement.landmarks)


def test_a_small_plan_keeps_the_usual_size(tmp_path):
    placement = place_markers(hall_plan(tmp_path, 6.0))
    assert placement.landmarks.size == STANDARD_SIZE_M
    assert placement.notes == []


def test_markers_too_small_for_a_stop_are_said_so(tmp_path):
    plan = hall_plan(tmp_path, 12.0)
    placement = place_markers(plan, size=STANDARD_SIZE_M)
    assert placement.landmarks.size == STANDARD_SIZE_M
    assert [note.split(":")[0] for note in placement.notes] == ["hall"]
    assert "6.0 m off" in placement.notes[0] and "--size" in placement.notes[0]
    assert not every_stop_reads(plan, placement.landmarks)


def test_a_stop_that_reads_too_few_gets_one_on_its_nearest_wall(tmp_path):
    plan = hall_plan(tmp_path, 7.0)
    # Markers only beside the door (no wall is 100 m long): the hall's stop, 3.5 m from
    # its walls, reads the hall's door marker only, and too far off for its facing.
    before = place_markers(plan, every=100.0, size=STANDARD_SIZE_M)
    beside = before.landmarks.markers[: before.beside_doors]
    hall = plan.rooms["hall"]
    sight = marker_walls(plan).segments
    assert not reads(hall.at, poses_of(beside), sight, STANDARD_SIZE_M)
    assert before.for_stops >= 1 and before.notes == []
    assert every_stop_reads(plan, before.landmarks)
    new = before.landmarks.markers[len(beside) :]
    seen = dict(visible_markers(poses_of(new), sight, hall.at, STANDARD_SIZE_M))
    assert {marker.id for marker in new} == set(seen)
    # On the wall nearest the stop, square in front of it.
    assert min(math.dist(hall.at, marker.at) for marker in new) == 3.5
