"""A doorway drawn off the real one is crossed where the lidar sees it (issue 29): its
revolutions, cast in the real building's pixels, move the planned crossing towards the
real middle, as far as the plan's own walls leave it clear; a revolution that does not
show the opening, or shows it smeared, changes nothing; and a mission stops once to plan
a crossing seen off its plan again, only where it can still line up on it."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from giraff_console.lidar.scan import LidarScan
from giraff_console.missions.door_sighting import (
    MAX_SHIFT_M,
    MIN_SIGHTINGS,
    Doorway,
    Revolution,
    Sightings,
    opening_middle,
)
from giraff_console.missions.lookout import Lookout
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import FloorPlan, load_floorplan
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M, walls_of
from giraff_console.robot.odometry import Pose

TWO_ROOMS = Path(__file__).parent.parent / "lidar" / "two_rooms.yaml"
# The real door's middle, 7.5 cm along the wall from the plan's (1.5): the taught home's
# worst 0.8 m door.
REAL_Y = 1.575
HALL = Pose(3.5, 1.5, 0.0)  # 1.5 m before the door, facing it
WIDTH = 2 * ROBOT_RADIUS_M


def two_rooms(tmp_path: Path, name: str, door_y: float, width: float) -> FloorPlan:
    plan = yaml.safe_load(TWO_ROOMS.read_text())
    plan["doors"][0].update(at=[5, door_y], width=width)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(plan))
    return load_floorplan(path)


def revolution(truth: OccupancyGrid, pose: Pose, taken_at: float) -> LidarScan:
    """A revolution of 360 beams from `pose`, each ending on the first occupied pixel of
    the real building's grid along it (in 1 cm steps), as a lidar's would."""
    beams = []
    for degree in range(360):
        bearing = math.radians(degree - 180)
        angle = pose.heading + bearing
        for step in range(1, 1200):
            reach = step * 0.01
            try:
                row, col = truth.cell_of(pose.x + reach * math.cos(angle),
                                         pose.y + reach * math.sin(angle))  # fmt: skip
            except ValueError:
                break
            if truth.cells[row, col] == OCCUPIED:
                beams.append((reach, bearing))
                break
    return LidarScan(12.0, tuple(beams), taken_at, len(beams))


def crossing_y(navigator: Navigator) -> float:
    """Where the plan from the hall to the ward crosses the door, along its wall."""
    planned = navigator.go("ward", HALL)
    (middle,) = planned.doorways
    assert middle[0] == pytest.approx(5.0)
    return middle[1]


def sweep(lookout: Lookout, truth: OccupancyGrid, revolutions: int, whole: bool = True) -> None:
    """`revolutions` of the real building read by `lookout` from the hall, each at two
    ticks, as the loop reads the latest; the first, taken before the mission's first
    tick, is not placed at all. Not `whole`: each marked as having lost samples."""
    scans = [replace(revolution(truth, HALL, taken_at=0.2 * i), whole=whole)
             for i in range(revolutions + 1)]  # fmt: skip
    reading = iter(scan for scan in scans for _ in range(2))
    lookout.sense = lambda: next(reading)
    for scan in scans:
        for late in (0.01, 0.05):
            lookout.sweep(HALL, scan.taken_at + late)


def seen(tmp_path: Path, plan_width: float, revolutions: int, real_width: float | None = None,
         whole: bool = True, real_y: float = REAL_Y) -> tuple[Navigator, Lookout]:  # fmt: skip
    """The navigator of a plan whose door is `plan_width` wide at y 1.5, after a lookout
    has read `revolutions` of the real building (its door `real_width`, else as wide, at
    `real_y`), and the lookout."""
    plan = two_rooms(tmp_path, "plan", 1.5, plan_width)
    truth = walls_of(two_rooms(tmp_path, "truth", real_y, real_width or plan_width))
    assert truth is not None
    navigator = Navigator(plan, walls_of(plan))
    lookout = Lookout(navigator, lambda: revolution(truth, HALL, 0.0))
    sweep(lookout, truth, revolutions, whole)
    return navigator, lookout


def test_a_doorway_seen_off_the_plans_middle_is_crossed_where_it_was_seen(tmp_path):
    # The plan's door 0.9 m wide, as is the real one: its middle is within its clearance.
    assert crossing_y(seen(tmp_path, 0.9, 0)[0]) == pytest.approx(1.5)
    assert crossing_y(seen(tmp_path, 0.9, MIN_SIGHTINGS)[0]) == pytest.approx(REAL_Y, abs=0.02)


def test_revolutions_with_samples_lost_do_not_move_the_crossing(tmp_path):
    # Pieces of turns (lidar/scan.py's whole_turn) show what is in the way, not where
    # a doorway is: as many as move it when whole leave the plan's crossing.
    navigator, _ = seen(tmp_path, 0.9, MIN_SIGHTINGS + 2, whole=False)
    assert crossing_y(navigator) == pytest.approx(1.5)


def test_a_few_revolutions_do_not_move_the_crossing(tmp_path):
    # One revolution's jamb may be a beam's spacing off: the median of a few.
    assert crossing_y(seen(tmp_path, 0.9, MIN_SIGHTINGS - 1)[0]) == pytest.approx(1.5)


def test_the_crossing_keeps_the_plans_clearance_nearest_the_middle_seen(tmp_path):
    # The plan's door 0.8 m wide, as the real one is, 7.5 cm off it: its walls grown by
    # the radius and the clearance leave the crossing's line 10 cm; the crossing comes as
    # near the real middle as they leave it clear.
    navigator, _ = seen(tmp_path, 0.8, MIN_SIGHTINGS)
    y = crossing_y(navigator)
    legs = navigator.planner.legs
    assert legs is not None
    assert legs.clear((4.1, y), (5.9, y))
    assert not legs.clear((4.1, y + 0.015), (5.9, y + 0.015))
    # The body clears the real jamb by 3 cm more than through the plan's middle, and by
    # the clearance the plan's walls are grown by.
    real_jamb = REAL_Y - 0.4
    assert y - 1.5 >= 0.03
    assert y - real_jamb - ROBOT_RADIUS_M >= CLEARANCE_M


def test_a_robot_short_of_the_doorway_lines_up_on_the_middle_seen(tmp_path):
    # Stopped in the crossing's run in, 0.8 m short of the door on the plan's old line,
    # it drives to the middle seen and straight on from there; 0.3 m short, straight to
    # the exit, as before (no hop sideways in the frame).
    navigator, _ = seen(tmp_path, 0.9, MIN_SIGHTINGS)
    far = navigator.go("ward", Pose(4.2, 1.5, 0.0)).path
    middle = (5.0, pytest.approx(REAL_Y, abs=0.02))
    assert far[1] == middle and far[2][1] == far[1][1]
    near = navigator.go("ward", Pose(4.7, 1.5, 0.0)).path
    assert near[1][0] > 5.4


def doorway() -> Doorway:
    door = load_floorplan(TWO_ROOMS).doors[0]  # 0.8 m wide at (5, 1.5), in the wall x = 5
    return Doorway(door, (0.0, 1.0))


def wall_with_opening(low: float, high: float, x: float = 4.95) -> np.ndarray:
    """Hits every 3 cm along the wall's face at `x`, but for the opening low-high."""
    return np.array([(x, y) for y in np.arange(0.0, 3.0, 0.03) if not low < y < high])


def test_both_jambs_seen_place_the_middle():
    hits = wall_with_opening(REAL_Y - 0.4, REAL_Y + 0.4)
    assert opening_middle(doorway(), hits, WIDTH) == pytest.approx(REAL_Y - 1.5, abs=0.02)


def test_one_jamb_says_nothing():
    hits = wall_with_opening(REAL_Y - 0.4, REAL_Y + 0.4)
    assert opening_middle(doorway(), hits[hits[:, 1] < 1.5], WIDTH) is None


@pytest.mark.parametrize("real_y", [REAL_Y, 1.65])
def test_a_doorway_drawn_wider_than_the_real_one_is_crossed_where_it_was_seen(tmp_path, real_y):
    # A taught map's 1.10 m for a real 0.80 m: the opening seen is narrower than the
    # plan's less 5 cm, and still the doorway (before, refused as something standing in
    # it). At 1.65 a real jamb (1.25) stands 0.3 m inside the plan's doorway (0.95-2.05),
    # beyond KNOWN_WALL_M of its wall: something in the way to the lookout, which before
    # left no straight crossing at all.
    navigator, _ = seen(tmp_path, 1.1, MIN_SIGHTINGS, real_width=0.8, real_y=real_y)
    assert bool(navigator.state.obstacles) == (real_y == 1.65)
    y = crossing_y(navigator)
    # Nearest the middle seen that the jamb sensed leaves clear: the body passes both
    # real jambs by the clearance.
    assert y == pytest.approx(real_y, abs=0.03)
    assert y - ROBOT_RADIUS_M - (real_y - 0.4) >= CLEARANCE_M
    assert real_y + 0.4 - (y + ROBOT_RADIUS_M) >= CLEARANCE_M


def test_someone_at_the_side_of_a_doorway_is_passed_furthest_from():
    # A 0.96 m opening seen (0.99-1.95), someone at the wall's face 11 cm in from its
    # jamb: the middle of what is left, further from them.
    clear = wall_with_opening(1.0, 1.95)
    hits = np.vstack([clear, [(4.95, 1.1)]])
    assert opening_middle(doorway(), clear, WIDTH) == pytest.approx((0.99 + 1.95) / 2 - 1.5)
    assert opening_middle(doorway(), hits, WIDTH) == pytest.approx((1.1 + 1.95) / 2 - 1.5)


def test_an_opening_the_robot_cannot_pass_says_nothing():
    # Someone standing in the doorway, at the wall's face, leaves 0.68 m (1.3-1.98): less
    # than the robot and SIDE_M a side (0.75 m); 0.78 m (1.2-1.98) is enough.
    wall = wall_with_opening(REAL_Y - 0.4, REAL_Y + 0.4)
    assert opening_middle(doorway(), np.vstack([wall, [(4.95, 1.3)]]), WIDTH) is None
    assert opening_middle(doorway(), np.vstack([wall, [(4.95, 1.2)]]), WIDTH) is not None


def test_something_in_front_of_the_wall_is_not_its_jamb():
    # A chair 0.2 m in front of the wall, within the opening's span: not at the face.
    hits = np.vstack([wall_with_opening(REAL_Y - 0.4, REAL_Y + 0.4), [(4.75, 1.25)]])
    assert opening_middle(doorway(), hits, WIDTH) == pytest.approx(REAL_Y - 1.5, abs=0.02)


def test_an_opening_too_far_along_or_too_wide_is_another():
    near = 0.9 * MAX_SHIFT_M
    shown = wall_with_opening(1.5 + near - 0.4, 1.5 + near + 0.4)
    assert opening_middle(doorway(), shown, WIDTH) == pytest.approx(near, abs=0.02)
    far = 1.1 * MAX_SHIFT_M
    assert opening_middle(doorway(), wall_with_opening(1.5 + far - 0.4, 1.5 + far + 0.4),
                          WIDTH) is None  # fmt: skip
    assert opening_middle(doorway(), wall_with_opening(0.85, 2.15), WIDTH) is None


def test_a_smeared_revolution_says_nothing():
    hits = wall_with_opening(REAL_Y - 0.4, REAL_Y + 0.4)
    sightings = Sightings()

    def see(taken_at: float, **how) -> dict[str, float]:
        return sightings.see([doorway()], Revolution(hits, (3.5, 1.5), taken_at, **how), WIDTH)

    for taken_at in range(MIN_SIGHTINGS - 1):
        assert see(taken_at) == {}
    assert see(MIN_SIGHTINGS - 2) == {}  # the same revolution, read again
    assert see(10, turned=True) == {}  # turning as it was taken
    assert see(11, moved=(0.0, 0.05)) == {}  # moving along the wall
    assert see(12, moved=(0.2, 0.0)) == {"hall-ward": pytest.approx(REAL_Y - 1.5, abs=0.02)}


def test_sightings_that_disagree_place_no_middle():
    # Leaving a room after a turn on the spot, its heading being corrected: the door
    # seen -7, -11, -14 cm along its wall in three revolutions, where it is +5.
    sightings = Sightings()
    for taken_at, y in enumerate((1.5 - 0.07, 1.5 - 0.11, 1.5 - 0.14, 1.55, 1.55)):
        hits = wall_with_opening(y - 0.4, y + 0.4)
        found = sightings.see([doorway()], Revolution(hits, (3.5, 1.5), taken_at), WIDTH)
        assert found == {}, taken_at
    hits = wall_with_opening(1.55 - 0.4, 1.55 + 0.4)
    found = sightings.see([doorway()], Revolution(hits, (3.5, 1.5), 5), WIDTH)
    assert found == {"hall-ward": pytest.approx(0.05, abs=0.02)}


def test_a_mission_stops_once_for_a_doorway_seen_off_its_plan(tmp_path):
    plan = two_rooms(tmp_path, "plan", 1.5, 0.9)
    truth = walls_of(two_rooms(tmp_path, "truth", REAL_Y, 0.9))
    assert truth is not None
    navigator = Navigator(plan, walls_of(plan))
    crossings = navigator.go("ward", HALL).doorways  # planned before it saw the door
    lookout = Lookout(navigator, lambda: revolution(truth, HALL, 0.0))
    sweep(lookout, truth, MIN_SIGHTINGS)
    doors = ("hall-ward",)
    # Standing in a doorway: weighed only once out of it, where a stop is no turn in it.
    assert lookout.doorway_off(Pose(4.9, 1.5, 0.0), doors, crossings) is None
    off = lookout.doorway_off(HALL, doors, crossings)
    assert off is not None and off[0] == "hall-ward"
    assert off[1] == pytest.approx(REAL_Y - 1.5, abs=0.02)
    # Seen to move again (7.5 cm further): once a mission.
    first = navigator.crossing_middle("hall-ward")
    moved = walls_of(two_rooms(tmp_path, "moved", REAL_Y + 0.075, 0.9))
    assert moved is not None and first is not None
    sweep(lookout, moved, MIN_SIGHTINGS)
    again = navigator.crossing_middle("hall-ward")
    assert again is not None and again[1] > first[1] + 0.02
    assert lookout.doorway_off(HALL, doors, crossings) is None


@pytest.mark.parametrize("where", [Pose(4.2, 1.5, 0.0), Pose(3.5, 1.5, math.pi)],
                         ids=["too near to stop short", "behind"])  # fmt: skip
def test_no_stop_for_a_doorway_too_near_or_behind(tmp_path, where):
    navigator, lookout = seen(tmp_path, 0.9, 0)
    crossings = navigator.go("ward", HALL).doorways
    truth = walls_of(two_rooms(tmp_path, "truth", REAL_Y, 0.9))
    assert truth is not None
    sweep(lookout, truth, MIN_SIGHTINGS)
    assert lookout.doorway_off(where, ("hall-ward",), crossings) is None


def test_a_renamed_plan_keeps_the_middles_seen_and_a_new_building_does_not(tmp_path):
    navigator, _ = seen(tmp_path, 0.9, MIN_SIGHTINGS)
    navigator.use_plan(navigator.plan)
    assert crossing_y(navigator) == pytest.approx(REAL_Y, abs=0.02)
    navigator.use_building(navigator.plan, navigator.walls)
    assert crossing_y(navigator) == pytest.approx(1.5)
