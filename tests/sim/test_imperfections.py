"""The imperfection model: off by default, seeded, and each effect visible."""

from __future__ import annotations

import math

import pytest

from giraff_console.sim import BoardConfig, Imperfections
from tests.conftest import SimBench


def drive_square(sim: SimBench) -> None:
    sim.run("set a 0.5", "set v 0.3")
    for _ in range(4):
        sim.run("set r 1", "set p 1")
        sim.run_until_stopped(step=0.1)
        sim.run("set r 0", "set p 90")
        sim.run_until_stopped(step=0.1)


def imperfect(seed: int, **overrides) -> SimBench:
    config = Imperfections.realistic(seed)
    if overrides:
        config = Imperfections(**{**config.__dict__, **overrides})
    return SimBench(BoardConfig(imperfections=config))


def test_off_by_default_the_square_closes_exactly(sim):
    drive_square(sim)
    pose = sim.board.true_pose
    assert (pose.x, pose.y) == pytest.approx((0, 0), abs=1e-9)


def test_same_seed_same_world():
    poses = []
    for _ in range(2):
        sim = imperfect(7, stall_rate=0, estop_rate=0)
        drive_square(sim)
        poses.append(sim.board.true_pose)
    assert poses[0] == poses[1]
    other = imperfect(8, stall_rate=0, estop_rate=0)
    drive_square(other)
    assert other.board.true_pose != poses[0]


def test_moves_miss_their_target_by_a_few_millimetres_and_report_it():
    sim = imperfect(3, caster_drift_deg=0, stall_rate=0, estop_rate=0)
    misses = []
    for _ in range(10):
        sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 0.5")
        sim.run_until_stopped()
        misses.append(sim.bulk()["cdis"] - 0.5)
    assert all(abs(miss) <= 0.009 for miss in misses)
    assert any(abs(miss) > 0.0005 for miss in misses)
    # The board reports what the wheels really did: odometers and truth agree.
    assert sim.bulk()["imdl"] == pytest.approx(sim.board.true_pose.x, abs=1e-6)


def test_casters_turn_the_robot_after_rotating_in_place_unseen_by_the_wheels():
    sim = imperfect(5, move_error_m=0, stall_rate=0, estop_rate=0)
    sim.run("set r 0", "set a 0.5", "set v 0.3", "set p 90")
    sim.run_until_stopped()
    sim.run("set r 1", "set p 1")
    sim.run_until_stopped()
    bulk = sim.bulk()
    assert bulk["imdl"] - bulk["imdr"] == pytest.approx(2 * 90 / 229.6, rel=1e-2)
    extra = math.degrees(sim.board.true_pose.heading) + 90
    assert -45.0 <= extra < -1.0  # turned further clockwise, at most §3.2.1.5's 45°


def test_random_stalls_happen_when_likely():
    sim = imperfect(1, stall_rate=100.0, estop_rate=0)
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    stalled_samples = 0
    while sim.bulk()["mode"] & 128:
        if sim.bulk()["gvr"] == 0:
            stalled_samples += 1
        sim.advance(0.05)
    assert stalled_samples >= 8  # at least half a second at 20 Hz


def test_random_estop_stops_the_move_and_clears_later():
    sim = imperfect(2, estop_rate=100.0, stall_rate=0)
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 5")
    sim.advance(20)
    assert sim.board.true_pose.x < 5
    modes = set()
    sim2 = imperfect(2, estop_rate=100.0, stall_rate=0)
    sim2.run("set r 1", "set a 0.5", "set v 0.4", "set p 5")
    for _ in range(400):
        modes.add(sim2.bulk()["mode"])
        sim2.advance(0.05)
    assert 8 in modes
    assert sim2.bulk()["mode"] == 0
