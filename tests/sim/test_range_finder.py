"""The simulated range finder the thesis recommends adding (§6): what it reads, and where."""

from __future__ import annotations

import math

import pytest

from giraff_console.sim.drive import TruePose
from giraff_console.sim.range_finder import SimRangeFinder
from giraff_console.sim.surroundings import Surroundings

SIZE = 0.5
ORIGIN = TruePose(0.0, 0.0, 0.0)


def finder(things: Surroundings, pose: TruePose = ORIGIN, **kwargs: float) -> SimRangeFinder:
    return SimRangeFinder(lambda: pose, things, **kwargs)


def nearest(readings: list[tuple[float, float]]) -> tuple[float, float]:
    return min(readings, key=lambda reading: abs(reading[1]))


def test_a_block_ahead_reads_its_near_face_straight_ahead():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    readings = finder(things).readings().hits
    # 36 beams over 70 degrees are 2 degrees apart, the middle two 1 degree either side.
    face = 1.0 - SIZE / 2
    step = math.radians(70) / 35
    distance, bearing = nearest(readings)
    assert abs(bearing) == pytest.approx(step / 2)
    assert distance == pytest.approx(face / math.cos(step / 2))
    # Every beam meeting the flat face reads face / cos(bearing).
    for distance, bearing in readings:
        assert distance == pytest.approx(face / math.cos(bearing))


def test_only_the_beams_that_meet_the_block_read_it():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    readings = finder(things).readings().hits
    # The face's corners are at atan(0.25 / 0.75) either side; the back corners are hidden.
    edge = math.atan2(SIZE / 2, 1.0 - SIZE / 2)
    step = math.radians(70) / 35
    beams_on_face = 2 * (math.floor((edge - step / 2) / step) + 1)
    assert len(readings) == beams_on_face
    assert all(abs(bearing) <= edge for _, bearing in readings)


def test_readings_go_from_right_to_left():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    bearings = [bearing for _, bearing in finder(things).readings().hits]
    assert bearings == sorted(bearings)


def test_nothing_beyond_range_is_read():
    things = Surroundings()
    things.block(2.0, 0.0, size=SIZE)  # near face 1.75 m away, range 1.5 m
    assert finder(things).readings().hits == []
    # The same block seen by a finder with a longer reach.
    distance, _ = nearest(finder(things, range_m=2.0).readings().hits)
    assert distance == pytest.approx((2.0 - SIZE / 2) / math.cos(math.radians(1)))


def test_nothing_outside_the_field_of_view_is_read():
    things = Surroundings()
    # 45 degrees to the left, 1 m away: outside +-35 degrees, even its nearest corner.
    things.block(math.cos(math.pi / 4), math.sin(math.pi / 4), size=0.2)
    corner = math.atan2(math.sin(math.pi / 4) - 0.1, math.cos(math.pi / 4) + 0.1)
    assert math.degrees(corner) > 35
    assert finder(things).readings().hits == []
    assert finder(things, fov_deg=120).readings().hits != []


def test_a_closed_door_across_the_way_is_read():
    things = Surroundings()
    things.close_door("lab", (0.8, -0.45), (0.8, 0.45))
    readings = finder(things).readings().hits
    distance, _ = nearest(readings)
    assert distance == pytest.approx(0.8 / math.cos(math.radians(1)))
    # Beams that miss the door's jambs, at more than atan(0.45 / 0.8) = 29.4 degrees, read nothing.
    assert max(abs(bearing) for _, bearing in readings) < math.atan2(0.45, 0.8)
    assert len(readings) == 30  # 15 beams either side, at 1, 3, ..., 29 degrees
    things.open_door("lab")
    assert finder(things).readings().hits == []


def test_the_building_walls_are_not_read():
    # In an empty Surroundings there is nothing to see, whatever the floor plan has.
    assert finder(Surroundings()).readings().hits == []


def test_readings_are_in_the_robots_frame_when_it_is_turned():
    things = Surroundings()
    # The robot at (2, 3) faces +y (90 degrees); the block is 1 m ahead of it.
    things.block(2.0, 4.0, size=SIZE)
    turned = finder(things, TruePose(2.0, 3.0, math.pi / 2)).readings().hits
    distance, bearing = nearest(turned)
    assert abs(bearing) == pytest.approx(math.radians(1))
    assert distance == pytest.approx((1.0 - SIZE / 2) / math.cos(math.radians(1)))
    # A block 1 m to the left of a robot facing +x reads at bearing +90 degrees.
    things_left = Surroundings()
    things_left.block(0.0, 0.0, size=SIZE)
    left = finder(things_left, TruePose(0.0, -1.0, 0.0), fov_deg=180, rays=181).readings().hits
    distance, bearing = min(left)
    assert bearing == pytest.approx(math.pi / 2)
    assert distance == pytest.approx(1.0 - SIZE / 2)


def test_scan_points_lie_on_the_blocks_near_face_on_the_map():
    things = Surroundings()
    things.block(2.0, 4.0, size=SIZE)
    points = finder(things, TruePose(2.0, 3.0, math.pi / 2)).scan_points()
    assert len(points) > 4
    for x, y in points:
        assert y == pytest.approx(4.0 - SIZE / 2)
        assert abs(x - 2.0) <= SIZE / 2 + 1e-9


def test_one_beam_looks_straight_ahead():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    assert finder(things, rays=1).readings().hits == [pytest.approx((1.0 - SIZE / 2, 0.0))]


def test_the_finder_reads_the_pose_it_is_given_each_time():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    poses = iter([TruePose(0.0, 0.0, 0.0), TruePose(0.5, 0.0, 0.0)])
    sensor = SimRangeFinder(lambda: next(poses), things)
    first = nearest(sensor.readings().hits)[0]
    second = nearest(sensor.readings().hits)[0]
    assert first - second == pytest.approx(0.5 / math.cos(math.radians(1)))


def test_every_beam_is_reported_those_that_meet_nothing_at_infinity():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    scan = finder(things).readings()
    assert scan.range_max == 1.5
    assert len(scan.beams) == 36
    assert [bearing for _, bearing in scan.beams] == pytest.approx(finder(things).bearings)
    # The beams either side of the block see free space out to the range and beyond.
    edge = math.atan2(SIZE / 2, 1.0 - SIZE / 2)
    for distance, bearing in scan.beams:
        assert (distance == math.inf) == (abs(bearing) > edge)


def test_with_nothing_about_every_beam_reads_infinity():
    scan = finder(Surroundings(), range_m=2.0).readings()
    assert scan.range_max == 2.0
    assert [distance for distance, _ in scan.beams] == [math.inf] * 36


def test_a_block_taken_away_leaves_free_beams_where_it_was():
    things = Surroundings()
    things.block(1.0, 0.0, size=SIZE)
    sensor = finder(things)
    assert sensor.readings().hits
    things.unblock(1.0, 0.0)
    assert all(distance == math.inf for distance, _ in sensor.readings().beams)
