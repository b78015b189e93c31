"""Simulated motion against closed-form kinematics (A.1-A.2, B.2 GiraffMotorSim).

Every test drives the board through its command interpreter on a virtual clock and
reads what a host would read: bulk_data.
"""

from __future__ import annotations

import math

import pytest

from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, TURN_RADIUS_M
from giraff_console.sim import BoardConfig, Imperfections
from tests.conftest import SimBench

V, A = 0.4, 0.5  # the thesis's KBD_MOVE_SPEED and DEF_ACCEL


def straight(sim: SimBench, p: float, v: float = V, a: float = A) -> None:
    sim.run("set r 1", f"set a {a}", f"set v {v}", f"set p {p}")


def test_trapezoid_matches_closed_form(sim):
    straight(sim, 1)
    ramp = V / A  # 0.8 s and 0.16 m of each ramp
    sim.advance(0.4)
    assert sim.bulk()["cdis"] == pytest.approx(A * 0.4**2 / 2, abs=1e-6)
    assert sim.bulk()["gvr"] == pytest.approx(A * 0.4, abs=1e-6)
    sim.advance(1.6)  # t = 2.0, cruising
    assert sim.bulk()["cdis"] == pytest.approx(0.16 + V * (2.0 - ramp), abs=1e-6)
    assert sim.bulk()["gvr"] == pytest.approx(V, abs=1e-6)
    sim.advance(3.3 - 2.0 - 1e-6)
    assert sim.bulk()["mode"] & 128
    sim.advance(2e-6)
    state = sim.bulk()
    assert state["cdis"] == 1.0
    assert state["gvr"] == 0.0
    assert not state["mode"] & 128


def test_triangle_when_the_move_is_too_short_for_the_peak(sim):
    straight(sim, 0.1)
    peak = math.sqrt(A * 0.1)  # the ramps meet half way
    sim.advance(peak / A)
    assert sim.bulk()["gvr"] == pytest.approx(peak, abs=1e-6)
    assert sim.bulk()["cdis"] == pytest.approx(0.05, abs=1e-6)
    assert sim.run_until_stopped(step=0.001) == pytest.approx(peak / A, abs=0.002)


def test_backwards_moves_are_signed(sim):
    straight(sim, -0.5)
    sim.advance(0.4)
    assert sim.bulk()["gvr"] == pytest.approx(-0.2, abs=1e-6)
    sim.run_until_stopped()
    assert sim.bulk()["cdis"] == -0.5
    assert sim.board.true_pose.x == pytest.approx(-0.5, abs=1e-9)


def test_preempt_continues_from_the_current_speed(sim):
    straight(sim, 10)
    sim.advance(2.0)  # cruising at 0.4 m/s, 0.64 m travelled
    sim.run("set p 1")  # relative: one more metre from here
    state = sim.bulk()
    assert state["cdis"] == 0.0  # relative counters restart with the new move
    assert state["gvr"] == pytest.approx(V, abs=1e-6)
    # Already at peak: cruise 1 - 0.16 m, then brake 0.8 s.
    assert sim.run_until_stopped(step=0.001) == pytest.approx((1 - 0.16) / V + V / A, abs=0.002)
    assert sim.board.true_pose.x == pytest.approx(1.64, abs=1e-6)


def test_lower_speed_on_preempt_ramps_down_instead_of_jumping(sim):
    straight(sim, 10)
    sim.advance(2.0)
    sim.run("set v 0.2", "set p 2")
    sim.advance(0.2)
    assert sim.bulk()["gvr"] == pytest.approx(V - A * 0.2, abs=1e-6)


def test_reversal_when_the_new_target_is_inside_the_braking_distance(sim):
    straight(sim, 10)
    sim.advance(2.0)
    sim.run("set p 0.05")  # braking from 0.4 m/s needs 0.16 m
    brake = V**2 / (2 * A)
    back_speed = math.sqrt(A * (brake - 0.05))
    furthest = 0.0
    elapsed = 0.0
    while sim.bulk()["mode"] & 128:
        furthest = max(furthest, sim.bulk()["cdis"])
        sim.advance(0.001)
        elapsed += 0.001
    assert furthest == pytest.approx(brake, abs=1e-4)
    assert elapsed == pytest.approx((V + back_speed) / A + back_speed / A, abs=0.002)
    assert sim.bulk()["cdis"] == pytest.approx(0.05, abs=1e-7)
    assert sim.board.true_pose.x == pytest.approx(0.64 + 0.05, abs=1e-6)


def test_a_zero_target_brakes_and_comes_back_to_where_it_was_sent(sim):
    # B.2 plans "set p 0" like any target inside the braking distance. The thesis's
    # console therefore stopped with the braking distance plus a 10 ms margin (§3.2.1.2).
    straight(sim, 10)
    sim.advance(2.0)
    sim.run("set p 0")
    sim.run_until_stopped(step=0.001)
    assert sim.board.true_pose.x == pytest.approx(0.64, abs=1e-6)


def test_braking_distance_plus_margin_stops_without_reversing(sim):
    straight(sim, 10)
    sim.advance(2.0)
    sim.run(f"set p {V**2 / (2 * A) + V * 0.01}")
    while sim.bulk()["mode"] & 128:
        assert sim.bulk()["gvr"] >= 0
        sim.advance(0.005)
    assert sim.board.true_pose.x == pytest.approx(0.64 + 0.16 + 0.004, abs=1e-6)


def test_rotation_in_place_reports_cang_and_gvr_with_the_opposite_sign(sim):
    sim.run("set r 0", "set a 0.5", "set v 0.2", "set p 90")
    sim.advance(1.0)  # cruising: ramp 0.4 s
    state = sim.bulk()
    assert state["gvr"] == pytest.approx(-0.2 * TURN_FACTOR_DEG_PER_M, abs=1e-4)
    assert state["cdis"] == 0.0
    assert state["cang"] < 0
    wheel = 90 / TURN_FACTOR_DEG_PER_M
    expected = 2 * 0.4 + (wheel - 0.08) / 0.2 - 1.0
    assert sim.run_until_stopped(step=0.001) == pytest.approx(expected, abs=0.002)
    assert sim.bulk()["cang"] == pytest.approx(-90.0, abs=1e-4)
    pose = sim.board.true_pose
    assert math.degrees(pose.heading) == pytest.approx(-90.0, abs=1e-6)  # clockwise
    assert (pose.x, pose.y) == pytest.approx((0, 0), abs=1e-9)
    assert sim.bulk()["imdl"] == pytest.approx(wheel, abs=1e-6)
    assert sim.bulk()["imdr"] == pytest.approx(-wheel, abs=1e-6)


def fine_clothoid(segments: list[tuple[float, float, float]], step: float = 1e-5):
    """Integrate a path given as (length, vg_start, vg_end) pieces, independently of the sim."""
    x = y = heading = 0.0
    for length, start, end in segments:
        n = max(1, round(length / step))
        for i in range(n):
            vg = start + (end - start) * (i + 0.5) / n
            turn = -vg / TURN_RADIUS_M * (length / n)
            mid = heading + turn / 2
            x += length / n * math.cos(mid)
            y += length / n * math.sin(mid)
            heading += turn
    return x, y, heading


def test_curved_move_follows_the_gear_ratio_envelope(sim):
    sim.run(
        "set r 1000", "set a 0.5", "set v 0.4", "set vg 0.3", "set vgr 1", "set cdp 1", "set p 2"
    )
    sim.advance(0.8 + 0.14 / V)  # 0.3 m along: the ratio has just reached vg
    state = sim.bulk()
    assert state["cdis"] == pytest.approx(0.3, abs=1e-6)
    assert state["cvg"] == pytest.approx(0.3, abs=1e-5)
    # gvr is the left wheel by the manufacturer's formula v / (1 - vg) (§3.2.1.4).
    assert state["gvr"] == pytest.approx(V / (1 - 0.3), abs=1e-5)
    assert state["cang"] == 0.0
    sim.advance(0.8 / V)  # 1.1 m: ramping down from cdp = 1.0
    assert sim.bulk()["cvg"] == pytest.approx(0.2, abs=1e-5)
    sim.run_until_stopped(step=0.01)
    assert sim.bulk()["cvg"] == 0.0
    assert sim.bulk()["cdis"] == 2.0
    x, y, heading = fine_clothoid([(0.3, 0, 0.3), (0.7, 0.3, 0.3), (0.3, 0.3, 0), (0.7, 0, 0)])
    pose = sim.board.true_pose
    assert heading == pytest.approx(-0.3 / TURN_RADIUS_M, rel=1e-6)
    assert pose.heading == pytest.approx(heading, abs=1e-5)
    assert (pose.x, pose.y) == pytest.approx((x, y), abs=1e-5)


def test_curved_move_that_stops_before_the_ratio_is_back_resets_it(sim):
    sim.run(
        "set r 1000", "set a 0.5", "set v 0.4", "set vg 0.4", "set vgr 1", "set cdp 5", "set p 1"
    )
    sim.run_until_stopped()
    assert sim.bulk()["cvg"] == 0.0


def test_vgr_zero_makes_the_gear_ratio_jump_to_zero(sim):
    sim.run(
        "set r 1000", "set a 0.5", "set v 0.4", "set vg 0.3", "set vgr 1", "set cdp 5", "set p 10"
    )
    sim.advance(3.0)
    assert sim.bulk()["cvg"] == pytest.approx(0.3, abs=1e-6)
    sim.run("set vgr 0", "set p 5")  # the thesis's way out of a curve (§3.2.1.4)
    assert sim.bulk()["cvg"] == 0.0


def test_preempting_a_curve_ramps_the_ratio_down_by_vgr(sim):
    sim.run(
        "set r 1000", "set a 0.5", "set v 0.4", "set vg 0.3", "set vgr 1", "set cdp 5", "set p 10"
    )
    sim.advance(3.0)
    sim.run("set cdp 0", "set p 5")  # straight, but the ratio must come down gradually
    assert sim.bulk()["cvg"] == pytest.approx(0.3, abs=1e-6)
    sim.advance(0.25)  # 0.1 m at cruise: ratio down by 0.1
    assert sim.bulk()["cvg"] == pytest.approx(0.2, abs=1e-5)


def test_left_turns_take_a_negative_vgr(sim):
    sim.run(
        "set r 1000", "set a 0.5", "set v 0.4", "set vg -0.3", "set vgr -1", "set cdp 1", "set p 2"
    )
    sim.advance(2.0)
    assert sim.bulk()["cvg"] == pytest.approx(-0.3, abs=1e-5)
    sim.run_until_stopped()
    assert sim.board.true_pose.heading == pytest.approx(0.3 / TURN_RADIUS_M, rel=1e-4)


def test_absolute_mode_targets_positions_and_counts_on(sim):
    sim.run("set mode 1", "set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.run_until_stopped()
    sim.run("set p 1.5")
    sim.run_until_stopped()
    state = sim.bulk()
    assert state["cdis"] == pytest.approx(1.5, abs=1e-6)
    assert state["imdl"] == pytest.approx(1.5, abs=1e-6)
    assert sim.board.true_pose.x == pytest.approx(1.5, abs=1e-6)


def test_relative_mode_counts_from_each_move(sim):
    straight(sim, 1)
    sim.run_until_stopped()
    sim.run("set p 1")
    sim.run_until_stopped()
    assert sim.bulk()["cdis"] == 1.0
    assert sim.bulk()["imdl"] == pytest.approx(2.0, abs=1e-6)


def test_changing_style_resets_the_absolute_position(sim):
    sim.run("set mode 1", "set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.run_until_stopped()
    sim.run("set r 0", "set p 90")
    sim.run_until_stopped()
    sim.run("set r 1", "set p 0.5")  # counts from zero again
    sim.run_until_stopped()
    assert sim.bulk()["cdis"] == pytest.approx(0.5, abs=1e-6)


def test_buffered_moves_queue_in_four_slots(sim):
    straight(sim, 0.5)
    for _ in range(3):
        sim.run("set mode 4", "set p 0.5")
    sim.cmd("set mode 4")
    assert sim.cmd("set p 0.5") == "ERROR: Queue rollover"
    sim.run_until_stopped()
    assert sim.bulk()["imdl"] == pytest.approx(2.0, abs=1e-6)
    assert sim.board.true_pose.x == pytest.approx(2.0, abs=1e-6)


def test_the_buffer_bit_applies_to_the_next_move_only(sim):
    straight(sim, 0.5)
    sim.run("set mode 4", "set p 0.5")
    sim.run("set p 0.25")  # the bit was used up: this preempts and drops the queued move
    sim.run_until_stopped()
    assert sim.bulk()["imdl"] < 0.5


def test_undock_backs_out_then_turns_around(sim):
    sim.run("set a 0.5", "set v 0.3", "set undock -0.5")
    assert sim.bulk()["mode"] & 128
    sim.run_until_stopped()
    pose = sim.board.true_pose
    assert pose.x == pytest.approx(-0.5, abs=1e-6)
    assert math.degrees(pose.heading) == pytest.approx(-180.0, abs=1e-6)
    assert sim.bulk()["cang"] == pytest.approx(-180.0, abs=1e-4)


def test_undock_needs_two_free_slots(sim):
    straight(sim, 0.5)
    sim.run("set mode 4", "set p 0.5", "set mode 4", "set p 0.5")
    assert sim.cmd("set undock 0.5") == "ERROR: Queue rollover"


def test_moving_bit_follows_the_motion(sim):
    assert sim.value("get mode") == 0
    straight(sim, 0.2)
    assert sim.value("get mode") == 128
    sim.run_until_stopped()
    assert sim.value("get mode") == 0


def test_zero_speed_is_refused_rather_than_divided_by(sim):
    sim.run("set v 0")
    assert sim.cmd("set p 1") == "Error: Argument out of range"


def test_negative_r_rotates_but_reports_wheel_metres(sim):
    # B.2 StartRotate: "If r is negative, the motion don't seem to get converted back
    # to angles, but are reported to the app as distances traveled by the wheels."
    sim.run("set r -1", "set a 0.5", "set v 0.2", "set p 90")
    sim.run_until_stopped()
    state = sim.bulk()
    assert state["cdis"] == pytest.approx(90 / TURN_FACTOR_DEG_PER_M, abs=1e-6)
    assert state["cang"] == 0.0
    assert math.degrees(sim.board.true_pose.heading) == pytest.approx(-90.0, abs=1e-6)


def test_switching_style_while_moving_brakes_before_turning(sim):
    straight(sim, 10)
    sim.advance(2.0)  # 0.64 m, cruising
    sim.run("set r 0", "set p 90")
    sim.run_until_stopped()
    pose = sim.board.true_pose
    assert pose.x == pytest.approx(0.64 + V**2 / (2 * A), abs=1e-6)
    assert math.degrees(pose.heading) == pytest.approx(-90.0, abs=1e-6)


@pytest.mark.parametrize("step", [0.5, 2.0, 3.0])
def test_mishaps_in_queued_moves_do_not_depend_on_how_time_is_advanced(step):
    # With seed 5 the first ESTOP is due 1.95 s into the motion: the first move (1.55 s)
    # runs clean and the second, queued, is cut by it.
    def bench() -> SimBench:
        sim = SimBench(BoardConfig(imperfections=Imperfections(estop_rate=0.5, seed=5)))
        sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 0.3", "set mode 4", "set p 0.3")
        return sim

    fine, coarse = bench(), bench()
    for _ in range(round(3.0 / 0.001)):
        fine.advance(0.001)
    for _ in range(round(3.0 / step)):
        coarse.advance(step)
    assert fine.bulk()["mode"] & 8
    assert 0.3 < fine.board.true_pose.x < 0.6
    assert coarse.board.true_pose.x == pytest.approx(fine.board.true_pose.x, abs=1e-9)
