"""The casters after a turn in place (§3.2.1.5): up to about 45° extra, settling as the
robot moves, never more however long it turned."""

from __future__ import annotations

import math

import pytest

from giraff_console.sim import BoardConfig, Imperfections
from giraff_console.sim.imperfections import ImperfectionModel
from tests.conftest import SimBench

WORST_DEG = 45.0  # "up to about 45 degrees extra" (§3.2.1.5)


def casters_only(seed: int) -> SimBench:
    config = Imperfections.realistic(seed)
    config = Imperfections(**{**config.__dict__, "move_error_m": 0.0, "stall_rate": 0.0,
                              "estop_rate": 0.0})  # fmt: skip
    return SimBench(BoardConfig(imperfections=config))


def heading_deg(sim: SimBench) -> float:
    return math.degrees(sim.board.true_pose.heading)


def turn(sim: SimBench, degrees: float) -> None:
    sim.run("set r 0", "set a 0.5", "set v 0.3", f"set p {degrees}")
    sim.run_until_stopped()


def forward(sim: SimBench, metres: float) -> None:
    sim.run("set r 1", "set a 0.5", "set v 0.3", f"set p {metres}")
    sim.run_until_stopped()


def test_the_realistic_robot_has_the_thesis_s_worst_case():
    assert Imperfections.realistic().caster_drift_deg == WORST_DEG


@pytest.mark.parametrize("seed", range(1, 11))
def test_a_quarter_turn_then_a_run_turns_up_to_45_degrees_extra(seed):
    sim = casters_only(seed)
    turn(sim, 90)
    forward(sim, 3.0)
    extra = -(heading_deg(sim) + 90)  # further clockwise, as the turn went
    # 30 % to 100 % of the worst case, all but 5e-5 of it made within 3 m (10 settling
    # lengths of 0.3 m).
    assert 0.3 * WORST_DEG * 0.999 <= extra <= WORST_DEG


def test_it_settles_as_the_robot_moves():
    sim = casters_only(4)
    turn(sim, 90)
    start = heading_deg(sim)
    forward(sim, 0.3)
    first = heading_deg(sim) - start
    forward(sim, 0.6)
    by_09 = heading_deg(sim) - start
    forward(sim, 2.0)
    total = heading_deg(sim) - start
    # 1 - 1/e of it in the first 0.3 m, 95 % within 0.9 m, nothing more to speak of after.
    assert first / total == pytest.approx(1 - math.exp(-1), rel=1e-3)
    assert by_09 / total == pytest.approx(1 - math.exp(-3), rel=1e-3)
    forward(sim, 2.0)
    assert heading_deg(sim) - start == pytest.approx(total, abs=5e-3)


def test_a_long_spin_is_no_worse_than_a_quarter_turn():
    for seed in range(1, 6):
        sim = casters_only(seed)
        for _ in range(8):  # two whole turns, stopping every quarter
            turn(sim, 90)
        forward(sim, 3.0)
        extra = -(heading_deg(sim) + 720)  # two turns clockwise, then the casters
        assert 0.0 < extra <= WORST_DEG


def test_teleop_s_many_short_turns_add_up_to_no_more_than_the_worst_case():
    model = ImperfectionModel(Imperfections(caster_drift_deg=WORST_DEG, seed=2))
    for _ in range(200):  # 20 s of a turn renewed every 0.1 s at 45°/s: 4.5 degrees each
        model.rotated_in_place(4.5)
    assert abs(model.caster_turn_over(100.0)) <= math.radians(WORST_DEG) + 1e-12


def test_a_turn_the_other_way_swings_the_casters_back():
    model = ImperfectionModel(Imperfections(caster_drift_deg=WORST_DEG, seed=3))
    model.rotated_in_place(90)
    after_one = model.caster_turn_over(100.0)
    assert after_one < 0  # a clockwise turn leaves them turning the robot clockwise
    model.rotated_in_place(-90)
    back = model.caster_turn_over(100.0)
    assert after_one < back <= math.radians(WORST_DEG)


def test_straight_runs_without_a_turn_in_place_keep_their_heading():
    sim = casters_only(6)
    forward(sim, 2.0)
    forward(sim, -1.0)
    assert heading_deg(sim) == 0.0
