"""Getting clear of a contact and trying again (issue 25, item 4): the policy, and the
care home's simulated board with its walls solid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.recovery import (
    BACK_OFF_M,
    MAX_CONTACTS,
    MISSION_CONTACTS,
    Recovery,
)
from giraff_console.motion.executor import Executor
from giraff_console.motion.path import Reverse
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.mission import Outcome
from giraff_console.robot.odometry import Pose
from tests.missions.site import LIMITS, PLAN, TICK, Site


@pytest.fixture
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def driven_east(recovery: Recovery, to: float) -> Pose:
    for x in np.arange(0.0, to + 1e-9, 0.05):
        recovery.trail(Pose(float(x), 0.0, 0.0))
    return Pose(to, 0.0, 0.0)


def test_a_robot_backs_off_the_way_it_came_as_far_as_that_runs_straight():
    recovery = Recovery()
    here = driven_east(recovery, 2.0)
    assert recovery.back_off(here) == BACK_OFF_M
    # Just round a corner: only as far back as the trail runs straight behind it.
    recovery = Recovery()
    for y in np.arange(-1.0, 0.0, 0.05):
        recovery.trail(Pose(0.0, float(y), math.pi / 2))
    for x in np.arange(0.0, 0.11, 0.05):
        recovery.trail(Pose(float(x), 0.0, 0.0))
    assert 0.05 <= recovery.back_off(Pose(0.1, 0.0, 0.0)) <= 0.11
    # No trail to follow (it never moved): it does not back at all.
    assert Recovery().back_off(Pose(0.0, 0.0, 0.0)) == 0.0


def test_a_contact_goes_on_the_grid_only_when_touched_again_where_no_wall_explains_it():
    cells = np.full((40, 40), FREE, dtype=np.uint8)
    cells[:, 30:] = OCCUPIED  # a wall from x = 3 m on, 0.1 m cells
    walls = OccupancyGrid(cells, 0.1)
    recovery = Recovery()
    here = driven_east(recovery, 1.0)
    first = recovery.touched(here, walls)
    assert not first.again and not first.explained and not first.unknown_obstacle
    second = recovery.touched(Pose(1.1, 0.0, 0.0), walls)
    assert second.again and second.unknown_obstacle
    # Against the plan's own wall: the pose was off, not the map.
    against = recovery.touched(Pose(2.7, 0.0, 0.0), walls)
    assert against.explained and not against.unknown_obstacle


def test_contacts_in_a_row_are_bounded_and_progress_between_them_resets_the_count():
    recovery = Recovery()
    recovery.replanned(10.0)
    for _ in range(MAX_CONTACTS - 1):
        recovery.touched(Pose(), None)
    assert not recovery.exhausted
    recovery.driven(9.0)  # a metre nearer: the next contact is a new place
    recovery.touched(Pose(), None)
    assert recovery.in_a_row == 1 and not recovery.exhausted
    for _ in range(MAX_CONTACTS - 1):
        recovery.touched(Pose(), None)
    assert recovery.exhausted
    assert recovery.touches == f"{MAX_CONTACTS} times in a row near {{}}"


def test_progress_counts_as_driven_tick_by_tick_only_past_where_it_touched():
    recovery = Recovery()
    recovery.replanned(5.0)
    recovery.touched(Pose(), None)
    # Backed off and planned again: the new plan is longer by the back-off, and driving
    # back over that stretch is no progress.
    recovery.replanned(5.0 + BACK_OFF_M)
    for left in np.arange(5.0 + BACK_OFF_M, 4.9, -0.01):
        recovery.driven(float(left))
    recovery.touched(Pose(), None)
    assert recovery.in_a_row == 2
    # Driven on, a centimetre a tick, well past where it touched: a new place.
    recovery.replanned(5.0 + BACK_OFF_M)
    for left in np.arange(5.0 + BACK_OFF_M, 4.5, -0.01):
        recovery.driven(float(left))
    recovery.touched(Pose(), None)
    assert recovery.in_a_row == 1


def test_contacts_in_one_mission_are_bounded_however_far_it_gets_between_them():
    recovery = Recovery()
    left = 50.0
    for _ in range(MISSION_CONTACTS):
        assert not recovery.exhausted
        recovery.replanned(left)
        left -= 1.0
        recovery.driven(left)  # a metre nearer each time
        recovery.touched(Pose(), None)
        assert recovery.in_a_row == 1
    assert recovery.exhausted
    assert recovery.touches == f"{MISSION_CONTACTS} times on the way, the last near {{}}"


def test_backing_off_is_a_jerk_limited_move_straight_back_within_the_reach(navigator):
    site = Site(navigator)
    start = site.true_pose()
    executor = Executor([Reverse(site.pose(), 0.25)], MotionLimits(), TICK)
    furthest_target = 0.0
    for _ in range(200):
        state = site.control.feed.poll(site.link)
        site.control.localisation.follow()
        for command in executor.step(site.clock.now(), state, site.pose()):
            site.link.send(command)
            if command.name == "p":
                furthest_target = min(furthest_target, float(command.settings["p"]))
        site.clock.advance(TICK)
        if executor.finished:
            break
    end = site.true_pose()
    assert executor.finished and executor.problem is None
    assert math.dist((start.x, start.y), (end.x, end.y)) == pytest.approx(0.25, abs=0.005)
    # Behind it, along its heading, never sent further back than the reach.
    behind = (end.x - start.x) * math.cos(start.heading) + (end.y - start.y) * math.sin(
        start.heading)  # fmt: skip
    assert behind < 0 and furthest_target >= -0.25
    assert executor.trace.max_jerk() <= LIMITS.j_max


def test_something_unseen_touched_twice_goes_on_the_grid_and_is_driven_round(navigator):
    """A low box in the corridor's middle, which the range finder does not see (no
    range finder here): the robot runs into it, backs off, tries again and runs into it
    again; then it is on the grid, the new way passes it, and the robot arrives."""
    site = Site(navigator)
    site.site.surroundings.block(15.0, 10.9, size=0.3)
    mission = site.start(GoTo(navigator, "kitchen", site.pose, tick=TICK, limits=LIMITS,
                              notify=site.notes.append))  # fmt: skip
    site.run(400)
    assert site.ended == ["done"], site.notes
    assert mission.contacts == 2 and mission.outcome is Outcome.ARRIVED_UNVERIFIED
    assert sum("backing off to try again" in note for note in site.notes) == 2
    end = site.true_pose()
    assert math.dist((end.x, end.y), PLAN.rooms["kitchen"].at) <= 0.03
    # What it felt is forgotten with the mission: the next one tries afresh.
    assert not navigator.state.obstacles


def test_a_robot_pinned_against_a_wall_backs_off_into_the_plans_free_floor():
    # A wall along y = 0; the robot touches it with its side (radius 0.3 m, 0.3 m off)
    # facing into it at 45 degrees, with no trail behind it: straight back is away from
    # the wall, as far as BACK_OFF_M.
    cells = np.full((60, 60), FREE, dtype=np.uint8)
    cells[-1, :] = OCCUPIED  # the bottom row: y from 0 to 0.05
    walls = OccupancyGrid(cells, 0.05, (0.0, 0.0))
    facing_in = Pose(1.5, 0.35, -math.pi / 4)
    assert Recovery().back_off(facing_in, walls) == BACK_OFF_M
    # Facing away from it, straight back is into it: it does not back at all.
    facing_out = Pose(1.5, 0.35, math.pi / 4)
    assert Recovery().back_off(facing_out, walls) == 0.0
    # On the wall by the estimate, or off the map: nothing behind is known to be free.
    assert Recovery().back_off(Pose(1.5, 0.02, -math.pi / 2), walls) == 0.0
    assert Recovery().back_off(Pose(-1.0, 1.0, 0.0), walls) == 0.0
