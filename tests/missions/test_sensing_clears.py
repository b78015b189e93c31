"""What the range finder sees clear is taken off the grid again (issue 12): a box that has
been taken away is not planned round for ever, while the floor plan's walls and a door
that is still shut stay blocked. In the simulated care home, on a virtual clock.

The thesis's grid squares are updated "as the robot moves" (§2.6.4); a beam that meets
nothing, or meets something further on, says that the squares it passed are free.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.missions.navigation import Navigator
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.odometry import Pose
from tests.missions.site import PLAN, Site

# Across the corridor, as in test_go_to: a trolley the corridor's width.
TROLLEY = (20.0, 11.0)
TROLLEY_SIZE = 1.9


@pytest.fixture
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def plan_blocked() -> np.ndarray:
    """The grid's cells the floor plan alone blocks: what no sensing may clear."""
    return Navigator(PLAN, walls_of(PLAN)).planner.legs.blocked


def beams(origin: tuple[float, float], reach: float, count: int = 720) -> list[tuple[float, float]]:
    """The ends of beams from `origin` all the way round, `reach` long: half a degree
    apart, a few centimetres at the corridor's trolley, so that every cell is crossed."""
    angles = np.linspace(0, 2 * math.pi, count, endpoint=False)
    return [(origin[0] + reach * math.cos(a), origin[1] + reach * math.sin(a)) for a in angles]


def across_corridor(x: float) -> list[tuple[float, float]]:
    """Points sensed in a line across the corridor at `x`, wall to wall."""
    return [(x, y) for y in np.arange(10.05, 12.0, 0.05)]


def test_a_trolley_taken_away_as_the_robot_stops_for_it_is_driven_through(navigator):
    site = Site(navigator)
    site.site.surroundings.block(*TROLLEY, size=TROLLEY_SIZE)
    mission = site.go("room-113")
    while not navigator.state.obstacles and site.clock.now() < 120:
        site.run(0.05)
    assert navigator.state.obstacles, "the range finder should see the trolley"
    assert not site.ended
    site.site.surroundings.unblock(*TROLLEY)
    site.run(600)
    assert site.ended == ["done"]
    assert mission.replans >= 1  # it did stop for the trolley
    # Once the robot looked again, the corridor was free: the new way goes along it
    # rather than round by the north corridor, as it must while the trolley is there.
    assert "north-corridor" not in mission.planned.route.rooms
    x, y = site.true_pose().x, site.true_pose().y
    assert math.dist((x, y), PLAN.rooms["room-113"].at) <= 0.03
    legs = navigator.planner.legs
    row, col = legs.grid.cell_of(*TROLLEY)
    assert not legs.blocked[row, col]
    assert not any(math.dist(point, TROLLEY) < 1.0 for point in navigator.state.obstacles)


def test_free_beams_clear_what_was_sensed_and_a_plan_through_exists_again(navigator):
    robot = navigator.start_pose
    navigator.report_obstacles(across_corridor(20.0))
    legs = navigator.planner.legs
    assert legs.path((16.0, 11.0), (24.0, 11.0), "corridor") is None
    # The range finder at (18, 11) looks along the corridor and sees nothing.
    changes = navigator.report_obstacles([], (18.0, 11.0), beams((18.0, 11.0), 3.0))
    assert changes and all(not blocked for _, blocked in changes)
    assert navigator.state.obstacles == ()
    assert np.array_equal(legs.blocked, plan_blocked())
    assert legs.path((16.0, 11.0), (24.0, 11.0), "corridor") is not None
    assert "north-corridor" not in navigator.go("room-113", robot).route.rooms


def test_the_leg_being_driven_is_told_of_cells_cleared(navigator):
    legs = navigator.planner.legs
    leg = legs.leg((16.0, 11.0), (24.0, 11.0), "corridor")
    straight = leg.cells()
    leg.update(navigator.report_obstacles(across_corridor(20.0)))
    assert leg.cells() is None
    leg.update(navigator.report_obstacles([], (18.0, 11.0), beams((18.0, 11.0), 3.0)))
    # D* Lite repairs its search to the way it found before anything was seen.
    assert leg.cells() == straight


def test_a_beam_that_hits_clears_up_to_what_it_hits_and_no_further(navigator):
    # Someone stood at x = 19, and has stepped back to x = 20.
    navigator.report_obstacles([(19.0, y) for y in np.arange(10.6, 11.45, 0.05)])
    # The beams from (17, 11) to x = 20 cross x = 19 between y = 10.53 and 11.53.
    hits = [(20.0, y) for y in np.arange(10.3, 11.8, 0.05)]
    navigator.report_obstacles(hits, (17.0, 11.0))
    sensed = navigator.state.obstacles
    assert sensed and all(x == pytest.approx(20.0) for x, _ in sensed)
    legs = navigator.planner.legs
    assert legs.blocked[legs.grid.cell_of(20.0, 11.0)]
    assert not legs.blocked[legs.grid.cell_of(19.0, 11.0)]


def test_the_same_thing_seen_again_changes_nothing(navigator):
    """Sensed every tick at 20 Hz, a box still there must cost nothing: the beams stop
    short of the cells their hits fall in, so a hit a centimetre off from the last one
    neither clears nor blocks anything."""
    here = (17.0, 11.0)
    hits = [(20.0, y) for y in np.arange(10.3, 11.8, 0.05)]
    assert navigator.report_obstacles(hits, here)
    seen = navigator.state.obstacles
    again = [(x + 0.01, y) for x, y in hits]
    assert navigator.report_obstacles(again, here) == []
    assert navigator.state.obstacles == seen


def test_free_beams_never_clear_the_floor_plans_walls(navigator):
    """Something sensed against the corridor's north wall, by room 105's door, then the
    beams look through it, the wall, the doorway and into the rooms either side."""
    navigator.report_obstacles([(x, 11.9) for x in np.arange(16.0, 20.0, 0.05)])
    legs = navigator.planner.legs
    plan = plan_blocked()
    assert (legs.blocked & ~plan).any()
    navigator.report_obstacles([], (18.0, 11.0), beams((18.0, 11.0), 4.0))
    assert np.array_equal(legs.blocked, plan)
    assert legs.blocked[legs.grid.cell_of(16.0, 12.0)]  # the wall itself


def test_a_door_shut_on_the_route_stays_blocked_while_the_robot_looks_at_it(navigator):
    site = Site(navigator)
    mission = site.go("day-room")
    site.run(20)  # along the corridor
    site.site.close_door("day-room-corridor")  # shut in the building, not on the plan
    site.run(600)
    assert site.ended == ["done"]
    assert "day-room-corridor" not in mission.planned.route.doors
    # Every sweep that met the door stopped short of it: its sensed cells are still
    # blocked, though the doorway is open on the floor plan.
    legs = navigator.planner.legs
    doorway = legs.grid.cell_of(36.0, 11.9)
    assert not plan_blocked()[doorway]
    assert legs.blocked[doorway]
    assert any(math.dist(point, (36.0, 12.0)) < 0.5 for point in navigator.state.obstacles)


def test_what_was_sensed_before_does_not_stop_a_new_mission_setting_off(navigator):
    # Something sensed across the dock's only doorway (a trolley, or the doorway's own
    # frames seen by a robot a few centimetres off its estimate): a way planned during
    # a mission goes round it or fails; a new mission clears it and sets off, to see
    # again what is really there (Nav2's clearing of the costmap).
    dock = Pose(2.0, 7.0, math.pi / 2)
    navigator.report_obstacles([(x, 10.3) for x in np.arange(1.4, 2.65, 0.05)])
    with pytest.raises(PlanningError):
        navigator.go("kitchen", dock)
    assert navigator.state.obstacles  # still believed
    planned = navigator.go("kitchen", dock, afresh=True)
    assert planned.path and not navigator.state.obstacles
