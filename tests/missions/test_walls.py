"""The simulated care home pushes back: a robot driven into a wall stops against it with
its wheels stalled, and the console sees the stall, as with a real robot (§2.3.2)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.clock import VirtualClock
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import ROBOT_RADIUS_M, walls_of
from giraff_console.robot.deadman import Intent
from giraff_console.robot.mission import Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import Telemetry
from giraff_console.runtime import sim_site
from giraff_console.runtime.sim_site import SimulatedSite
from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.move import TruePose
from giraff_console.sim.world import demo_world
from tests.listening import only
from tests.missions.site import LIMITS, PLAN, TICK, Site

MOVING = 128


@pytest.fixture(scope="module")
def shared_navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def test_the_building_is_solid_where_the_plan_has_walls_and_open_at_its_doorways(
    shared_navigator,
):
    solids = Site(shared_navigator).board.solids
    assert solids is not None and solids.radius == ROBOT_RADIUS_M
    # The dock's doorway into the corridor is 1.2 m wide at (2, 10).
    assert not solids.touches(2.0, 10.0)
    assert solids.touches(2.8, 9.8)  # beside it, against the wall
    assert solids.free_fraction(2.0, 9.0, 2.0, 11.0) == 1.0  # straight through
    assert solids.free_fraction(3.0, 9.0, 3.0, 11.0) == pytest.approx(0.35)  # into the wall


def test_a_go_into_a_wall_stops_against_it_backs_off_and_then_gives_up(shared_navigator):
    """The console thinks the robot is on its dock; it is really 0.8 m east of it, so the
    way north through the dock's doorway runs it into the wall beside the doorway. It
    backs off and tries again, three times in all: a doorway's frames are what a robot
    off its line clips, so nothing goes on the grid (the dock room would have no way
    out), and the mission ends and says so."""
    site = Site(shared_navigator)
    site.board.place(TruePose(2.8, 7.0, math.pi / 2))
    mission = site.go("kitchen")
    furthest = -math.inf
    for _ in range(round(120 / TICK)):
        site.control.tick()
        site.clock.advance(TICK)
        furthest = max(furthest, site.true_pose().y)
        if site.ended:
            break
    assert site.ended and "touched something 3 times in a row" in site.ended[0]
    assert mission.contacts == 3 and mission.outcome is Outcome.STALLED
    # Against the wall at y = 10, not a millimetre into it.
    assert furthest == pytest.approx(10.0 - ROBOT_RADIUS_M, abs=1e-9)
    # The robot is at rest where it stopped, and what it felt is no longer on the grid.
    pose = site.true_pose()
    site.run(3, until_ended=False)
    assert not site.board.drive.mode_bits() & MOVING
    assert site.true_pose() == pose
    assert not shared_navigator.state.obstacles


def test_teleop_into_a_wall_stalls_the_wheels_and_backing_off_works(shared_navigator):
    """Driving west across the dock room into its west wall at x = 0 with the keys."""
    site = Site(shared_navigator)
    start = Pose(2.0, 8.5, math.pi)
    site.board.place(TruePose(start.x, start.y, start.heading))
    site.control.odometry.reset(start)
    seen = []
    site.control.subscribe(only(Telemetry, lambda telemetry: seen.append(telemetry.state)))

    def hold(intent: Intent, seconds: float) -> None:
        for _ in range(round(seconds / TICK)):
            site.control.press(intent)
            site.control.tick()
            site.clock.advance(TICK)

    hold(Intent.FORWARD, 6.0)  # 1.7 m to the wall at 0.4 m/s, and more
    assert site.true_pose().x == pytest.approx(ROBOT_RADIUS_M, abs=1e-9)
    stalled = seen[-1]
    hold(Intent.FORWARD, 2.0)
    # What the console reads: the move commanded, the wheels still, no speed.
    now = seen[-1]
    assert now.mode & MOVING and now.gvr == 0.0 and now.speed == 0.0
    assert (now.imdl, now.imdr) == (stalled.imdl, stalled.imdr)
    # Its odometry stops where the robot stopped, since the wheels stopped there too.
    assert site.pose().x == pytest.approx(ROBOT_RADIUS_M, abs=1e-3)
    assert site.true_pose().x == pytest.approx(ROBOT_RADIUS_M, abs=1e-9)
    # Letting go stops it (nothing to brake: the board is at rest again), and the keys
    # then take it back off the wall.
    site.control.halt()
    site.run(1.0, until_ended=False)
    assert not site.board.drive.mode_bits() & MOVING
    hold(Intent.BACKWARD, 2.0)
    assert site.true_pose().x > ROBOT_RADIUS_M + 0.3


def test_a_door_shut_unseen_is_as_solid_as_a_wall(shared_navigator):
    """The dock's door shut behind the console's back, and no range finder to see it:
    the robot drives into the door and stalls against it, rather than through it."""
    site = Site(shared_navigator)
    site.site.close_door("dock-corridor")
    mission = site.start(GoTo(shared_navigator, "kitchen", site.pose, tick=TICK, limits=LIMITS))
    furthest = -math.inf
    while site.clock.now() < 60 and not site.ended:
        site.run(TICK)
        furthest = max(furthest, site.true_pose().y)
    # Against the door, three times, and never through it.
    assert site.ended and mission.contacts == 3 and mission.outcome is Outcome.STALLED
    assert furthest == pytest.approx(10.0 - ROBOT_RADIUS_M, abs=1e-9)
    # Opened again, the way is clear: the robot goes on where it left off.
    site.site.open_door("dock-corridor")
    site.ends.clear()
    site.go("kitchen")
    site.run(400)
    assert site.ended == ["done"]


def test_a_plan_with_a_grid_and_no_outlines_is_solid_where_the_grid_is_occupied(
    tmp_path, monkeypatch
):
    """Two rooms on a map of 0.1 m pixels: walls round the edge and between the rooms,
    with a gap to pass; no outlines, so the grid's occupied cells are the walls. (The
    camera's world is drawn from outlines alone, and has none to draw here.)"""
    monkeypatch.setattr(sim_site, "plan_world", lambda plan: demo_world())
    image = np.full((30, 60), 254, dtype=np.uint8)  # 6 m by 3 m, free
    image[[0, -1], :] = image[:, [0, -1]] = 0  # the outer walls
    image[:, 30] = 0  # a wall at x = 3.0 to 3.1 m ...
    image[10:20, 30] = 254  # ... with a 1 m gap, y = 1 to 2 m
    cv2.imwrite(str(tmp_path / "map.pgm"), image)
    (tmp_path / "plan.yaml").write_text(
        "name: Two rooms\n"
        "rooms:\n  west: {at: [1.5, 1.5]}\n  east: {at: [4.5, 1.5]}\n"
        "doors:\n  - {between: [west, east], at: [3.05, 1.5], width: 1.0}\n"
        "grid: {image: map.pgm, resolution: 0.1}\n"
        "start: west\n"
    )
    plan = load_floorplan(tmp_path / "plan.yaml")
    board = GiraffBoard(VirtualClock())
    SimulatedSite(board, plan, Pose(1.5, 0.5, 0.0))
    solids = board.solids
    assert solids is not None and solids.wall_count > 0
    # Along y = 0.5, the wall at x = 3.0 stops the robot 0.3 m short of it.
    assert solids.free_fraction(1.5, 0.5, 5.5, 0.5) == pytest.approx((3.0 - 0.3 - 1.5) / 4.0)
    assert solids.free_fraction(1.5, 1.5, 4.5, 1.5) == 1.0  # through the gap
    board.execute("set r 1")
    board.execute("set a 0.5")
    board.execute("set p 3")
    board.clock.advance(20.0)
    assert board.true_pose.x == pytest.approx(2.7, abs=1e-9)
