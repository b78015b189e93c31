"""Solid walls: a robot that drives into one stops against it, its wheels stalled."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from giraff_console.sim import BoardConfig, Imperfections
from giraff_console.sim.collision import Solids, grid_edges
from giraff_console.sim.move import TruePose
from giraff_console.sim.surroundings import Surroundings
from tests.conftest import SimBench

R = 0.3  # the planner's ROBOT_RADIUS_M, which the simulator takes as a parameter
MOVING = 128
# A wall across the robot's way, 1 m ahead, from y = -1 to y = 1.
AHEAD = ((1.0, -1.0), (1.0, 1.0))


def walled(*walls, surroundings: Surroundings | None = None, config: BoardConfig | None = None):
    sim = SimBench(config)
    sim.board.make_solid(Solids(walls, R, surroundings))
    return sim


def straight(sim: SimBench, p: float, v: float = 0.4) -> None:
    sim.run("set r 1", "set a 0.5", f"set v {v}", f"set p {p}")


def stalled(sim: SimBench) -> bool:
    """Whether the wheels are stalled now (the board catches up on a read)."""
    return bool(sim.bulk()["mode"] & MOVING) and sim.board.drive.stalled


def test_the_disc_meets_a_wall_where_its_edge_touches_it():
    solids = Solids([AHEAD], R)
    assert solids.free_fraction(0.0, 0.0, 1.0, 0.0) == pytest.approx(0.7)
    assert solids.free_fraction(0.0, 0.0, 0.5, 0.0) == 1.0
    # Beyond the wall's end, its round end is what the disc meets: at y = 1.2 the disc's
    # edge touches (1, 1) when the centre is sqrt(0.3^2 - 0.2^2) short of x = 1.
    assert solids.free_fraction(0.0, 1.2, 2.0, 1.2) == pytest.approx((1 - math.sqrt(0.05)) / 2)
    assert solids.free_fraction(0.0, 1.31, 2.0, 1.31) == 1.0  # passes the end clear
    # Slanting in: the centre comes within 0.3 m of the line x = 1.
    assert solids.free_fraction(0.0, 0.0, 1.0, 0.5) == pytest.approx(0.7)


def test_against_a_wall_only_motion_into_it_is_refused():
    solids = Solids([AHEAD], R)
    x = 0.7  # touching
    assert solids.free_fraction(x, 0.0, x + 0.1, 0.0) == 0.0
    assert solids.free_fraction(x, 0.0, x + 0.01, 0.3) == 0.0  # leaning in
    assert solids.free_fraction(x, 0.0, x - 0.1, 0.0) == 1.0  # backing off
    assert solids.free_fraction(x, 0.0, x, 0.5) == 1.0  # along it
    assert solids.free_fraction(x, 0.0, x - 0.01, -0.5) == 1.0  # along and away
    # Overlapping it (put down there): moving out is allowed, further in is not.
    assert solids.free_fraction(0.8, 0.0, 0.5, 0.0) == 1.0
    assert solids.free_fraction(0.8, 0.0, 0.85, 0.0) == 0.0


def test_a_robot_driving_into_a_wall_stops_against_it_with_its_wheels_stalled():
    sim = walled(AHEAD)
    straight(sim, 2.0)
    for _ in range(200):
        sim.advance(0.05)
        if stalled(sim):
            break
    pose = sim.board.true_pose
    assert pose.x == pytest.approx(1.0 - R, abs=1e-9) and pose.y == 0.0
    before = sim.bulk()
    # The move stays commanded; the wheels do not turn, so nothing the board reports moves.
    assert before["mode"] & MOVING
    assert before["gvr"] == 0.0
    sim.advance(3.0)
    later = sim.bulk()
    assert later["mode"] & MOVING
    assert later["gvr"] == 0.0
    for field in ("imdl", "imdr", "cdis"):
        assert later[field] == before[field]
    assert later["imdl"] == pytest.approx(0.7, abs=1e-6)  # the wheels turned as far as it went
    assert sim.board.true_pose == pose


def test_a_fast_robot_does_not_pass_through_a_wall_between_two_reads():
    sim = walled(AHEAD)
    straight(sim, 5.0, v=0.6)
    sim.advance(10.0)  # one long step: the whole move would end 4 m beyond the wall
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    assert stalled(sim)


def test_backing_off_and_turning_away_work_against_a_wall():
    sim = walled(AHEAD)
    straight(sim, 2.0)
    sim.advance(6.0)
    assert stalled(sim)
    # A new move starts from rest, the wheels having stopped: backing off works.
    straight(sim, -0.5)
    sim.run_until_stopped()
    assert sim.board.true_pose.x == pytest.approx(0.2, abs=1e-6)
    assert not stalled(sim)
    # Forward again: stopped at the wall again.
    straight(sim, 1.0)
    sim.advance(6.0)
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    # A turn in place against the wall: a turning disc keeps its footprint.
    sim.run("set r 0", "set p 90")
    sim.run_until_stopped()
    assert math.degrees(sim.board.true_pose.heading) == pytest.approx(-90, abs=1e-6)
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    # Then along the wall, touching it all the way.
    straight(sim, 0.5)
    sim.run_until_stopped()
    pose = sim.board.true_pose
    assert (pose.x, pose.y) == pytest.approx((0.7, -0.5), abs=1e-6)


def test_a_curve_into_a_wall_stops_against_it():
    sim = walled(AHEAD, ((-1.0, -1.0), (2.0, -1.0)))
    # Curving right (a positive gear ratio turns clockwise) towards the wall at y = -1.
    sim.run("set r 1000", "set a 0.5", "set v 0.4", "set vg 0.3", "set vgr 0", "set cdp 3")
    sim.run("set p 3")
    sim.advance(15.0)
    pose = sim.board.true_pose
    assert stalled(sim)
    assert sim.bulk()["mode"] & MOVING
    clearance = sim.board.solids.clearance(pose.x, pose.y)
    assert -1e-6 <= clearance <= 1e-6  # touching, not in it


def test_closed_doors_and_boxes_are_solid_and_an_opened_door_lets_it_through():
    things = Surroundings()
    things.close_door("d", (1.0, -0.6), (1.0, 0.6))
    sim = walled(surroundings=things)
    straight(sim, 2.0)
    sim.advance(6.0)
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    assert stalled(sim)
    things.open_door("d")
    sim.run_until_stopped()  # the commanded move carries on through the doorway
    assert sim.board.true_pose.x == pytest.approx(2.0, abs=1e-6)
    things.block(3.0, 0.0, size=0.5)
    straight(sim, 2.0)
    sim.advance(8.0)
    assert sim.board.true_pose.x == pytest.approx(3.0 - 0.25 - R, abs=1e-9)


def test_a_wall_stall_keeps_the_move_s_clock_so_mishaps_wait_with_it():
    sim = walled(AHEAD, config=BoardConfig(imperfections=Imperfections(stall_rate=0.0)))
    straight(sim, 2.0)
    sim.advance(4.0)
    drive = sim.board.drive
    stuck_at = drive._motion_time
    sim.advance(30.0)
    assert drive._motion_time == stuck_at
    assert drive.velocity == 0.0


def test_the_walls_outlast_a_power_cut_and_a_copied_board_shares_them():
    sim = walled(AHEAD)
    sim.board.power_off()
    straight(sim, 2.0)
    sim.advance(6.0)
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    assert copy.deepcopy(sim.board.drive).solids is sim.board.solids


def test_grid_edges_wrap_occupied_cells_in_merged_runs():
    occupied = np.zeros((4, 5), dtype=bool)
    occupied[1, 1:4] = True  # a bar three cells long, one high
    edges = grid_edges(occupied, 0.5, (10.0, 20.0))
    assert sorted(edges) == sorted([
        ((10.5, 21.5), (12.0, 21.5)), ((10.5, 21.0), (12.0, 21.0)),  # top and bottom
        ((10.5, 21.5), (10.5, 21.0)), ((12.0, 21.5), (12.0, 21.0)),  # left and right
    ])  # fmt: skip


def test_a_grid_without_outlines_is_solid_too():
    occupied = np.zeros((40, 40), dtype=bool)
    occupied[:, 30] = True  # a wall along x = 3.0..3.1 in 0.1 m cells
    solids = Solids.from_grid(occupied, 0.1, (0.0, 0.0), R)
    assert solids.free_fraction(1.0, 2.0, 4.0, 2.0) == pytest.approx((3.0 - R - 1.0) / 3.0)
    assert solids.touches(2.75, 2.0) and not solids.touches(2.65, 2.0)


def test_many_segments_are_looked_up_nearby_and_give_the_same_answers():
    rng = np.random.default_rng(1)
    walls = [
        ((float(x), float(y)), (float(x) + 0.05, float(y)))
        for x, y in rng.uniform(0, 40, (2000, 2))
    ]
    bucketed, flat = Solids(walls, R), Solids(walls, R)
    flat._buckets = None
    for x0, y0, x1, y1 in rng.uniform(0, 40, (300, 4)):
        x1, y1 = x0 + (x1 - x0) / 20, y0 + (y1 - y0) / 20
        assert bucketed.free_fraction(x0, y0, x1, y1) == flat.free_fraction(x0, y0, x1, y1)
        assert bucketed.clearance(x0, y0) == flat.clearance(x0, y0)


def test_a_place_off_the_walls_costs_no_geometry_per_step(monkeypatch):
    sim = walled(AHEAD, ((-5.0, 3.0), (5.0, 3.0)))
    sim.board.place(TruePose(-4.0, 0.0, 0.0))
    calls = []
    original = Solids.clearance
    monkeypatch.setattr(
        Solids, "clearance", lambda self, x, y: calls.append(x) or original(self, x, y)
    )
    straight(sim, 4.0)
    sim.run_until_stopped()
    # The clearance round a point is remembered: about one look per 0.7 m driven.
    assert sim.board.true_pose.x == pytest.approx(0.0, abs=1e-6)
    assert len(calls) <= 10


def test_a_stop_at_rest_against_a_wall_ends_at_once():
    """The console stops a robot at rest with a move of its braking distance, nothing:
    nothing to push, so the board is at rest again (a console waits for that)."""
    sim = walled(AHEAD)
    straight(sim, 2.0)
    sim.advance(6.0)
    assert stalled(sim)
    straight(sim, 0.0)
    sim.advance(0.05)
    assert not sim.bulk()["mode"] & MOVING
    assert not sim.board.drive.stalled


def test_a_move_that_brakes_through_zero_meets_the_wall_on_its_way_there():
    """0.1 m short of touching at 0.4 m/s, sent back: the board brakes through zero
    (0.16 m), so the robot touches the wall before it comes back, even when the whole
    move is run in one go."""
    sim = walled(AHEAD)
    straight(sim, 2.0)
    sim.advance(0.8 + 0.44 / 0.4)  # up to speed (0.16 m), then on to x = 0.6
    sim.bulk()
    assert sim.board.true_pose.x == pytest.approx(0.6, abs=1e-6)
    straight(sim, -0.5)
    sim.advance(20.0)
    assert sim.board.true_pose.x == pytest.approx(0.7, abs=1e-9)
    assert stalled(sim)
    straight(sim, -0.5)  # sent again, from rest: it backs off
    sim.run_until_stopped()
    assert sim.board.true_pose.x == pytest.approx(0.2, abs=1e-6)
