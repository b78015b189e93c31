"""How a later board moves: mode 2, Giraff-X's twm, braking on a zero speed, and a robot
whose real wheel base is not the firmware's."""

from __future__ import annotations

import math

import pytest

from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, WHEEL_BASE_M
from giraff_console.sim import BoardConfig, TruePose
from giraff_console.sim.firmware import FIRMWARES
from tests.conftest import SimBench

V, A = 0.4, 0.5


def board(name: str, **config) -> SimBench:
    return SimBench(BoardConfig(firmware=FIRMWARES[name], **config))


def heading_rate(sim: SimBench, seconds: float = 1.0) -> float:
    """Degrees per second the robot really turns, measured over `seconds`."""
    before = sim.board.true_pose.heading
    sim.advance(seconds)
    return math.degrees(sim.board.true_pose.heading - before) / seconds


@pytest.mark.parametrize("p", [3, -3])
def test_mode_2_turns_at_vg_degrees_per_second_either_way(p):
    sim = board("later")
    sim.run("set mode 2", "set r 0", f"set a {A}", f"set v {V}", "set vg 30", f"set p {p}")
    sim.advance(1.0)  # past the ramp (0.8 s)
    # Positive vg: counter-clockwise, forwards and backwards (wire-facts "What the
    # deployed drivers do", Sign in `mode 2`).
    assert heading_rate(sim) == pytest.approx(30.0, abs=1e-6)
    bulk = sim.bulk()
    assert bulk["mode"] == 2 | 128
    assert bulk["cdis"] == pytest.approx(math.copysign(0.16 + V * 1.2, p), abs=1e-6)
    sim.run_until_stopped()
    assert sim.bulk()["cdis"] == p  # r was not read: a path of |p| metres, not degrees


def test_the_thesis_board_ignores_mode_2():
    sim = board("thesis")
    sim.run("set mode 2", "set r 0", f"set a {A}", f"set v {V}", "set vg 30", "set p 3")
    assert sim.bulk()["mode"] == 128  # bit 2 stored by set mode, never read back
    sim.run_until_stopped()
    # r = 0: an ordinary turn in place of three degrees, clockwise.
    assert math.degrees(sim.board.true_pose.heading) == pytest.approx(-3.0, abs=1e-9)


def test_mode_2_renewed_every_tick_keeps_turning_smoothly():
    sim = board("later")
    sim.run("set mode 2", f"set a {A}", f"set v {V}", "set vg -20")
    for _ in range(40):  # a driver renewing p = 1 at 20 Hz (wire-facts "mode 2")
        sim.run("set p 1")
        sim.advance(0.05)
    assert heading_rate(sim, 0.05) == pytest.approx(-20.0, abs=1e-6)  # negative vg: right


@pytest.mark.parametrize("vg", [25, -25])
def test_a_positive_vg_curves_left_as_the_drivers_angular_velocity_does(vg):
    # The drivers send ROS's angular velocity (positive counter-clockwise) as vg
    # unchanged, and their robots turn left (wire-facts "What the deployed drivers do").
    sim = board("later")
    sim.run("set mode 2", f"set a {A}", f"set v {V}", f"set vg {vg}", "set p 1.5")
    sim.advance(1.0)
    # cvg is the board's gear ratio, positive to the right (A.2.3).
    assert math.copysign(1, sim.bulk()["cvg"]) == -math.copysign(1, vg)
    sim.run_until_stopped()
    pose = sim.board.true_pose
    assert math.copysign(1, pose.heading) == math.copysign(1, vg)
    assert math.copysign(1, pose.y) == math.copysign(1, vg)  # it went that way too


def spin(sim: SimBench, vg: float, p: float, seconds: float, tick: float = 0.05) -> None:
    """A driver turning on the spot in mode 2: v = 0, vg, p renewed every tick."""
    sim.run("set v 0", f"set vg {vg}")
    for _ in range(round(seconds / tick)):
        sim.run(f"set p {p}")
        sim.advance(tick)


@pytest.mark.parametrize("name", ["later", "giraff-x"])
@pytest.mark.parametrize(("vg", "p"), [(30, 1), (30, -1), (-45, 1), (-45, -1)])
def test_mode_2_with_v_0_turns_on_the_spot_at_vg_degrees_per_second(name, vg, p):
    # The drivers turn on the spot with set v 0, a non-zero vg and p = +-1, and the board
    # turns at that rate (wire-facts "What the deployed drivers do"); the direction is
    # vg's, whatever p's sign.
    sim = board(name)
    sim.run("set mode 2", f"set a {A}")
    spin(sim, vg, p, 2.0)  # the wheels reach radians(45) * 0.2495 m/s in 0.4 s at most
    assert heading_rate(sim, 0.05) == pytest.approx(vg, abs=1e-6)
    pose = sim.board.true_pose
    assert (pose.x, pose.y) == (0.0, 0.0)
    assert sim.bulk()["mode"] == 2 | 128


def test_a_turn_on_the_spot_that_is_not_renewed_ends_after_p_metres_of_each_wheel():
    # A driver that dies mid-turn leaves a bounded turn (assumption: |p| metres of wheel
    # travel, as every move counts p in wheel metres: 229.6 degrees for p = 1).
    sim = board("later")
    sim.run("set mode 2", f"set a {A}", "set v 0", "set vg 30", "set p 1")
    sim.run_until_stopped(limit=30.0)
    assert math.degrees(sim.board.true_pose.heading) == pytest.approx(TURN_FACTOR_DEG_PER_M)


@pytest.mark.parametrize("stop", [("set v 0", "set vg 0", "set p 0"),
                                  ("set a 0", "set v 0", "set p 0")])  # fmt: skip
def test_the_drivers_stop_idioms_stop_a_turn_on_the_spot(stop):
    sim = board("later")
    sim.run("set mode 2", f"set a {A}")
    spin(sim, 30, 1, 2.0)
    sim.run(*stop)
    assert sim.run_until_stopped(step=0.01) < 0.3  # braking at a from 0.13 m/s
    heading = sim.board.true_pose.heading
    sim.advance(5.0)
    assert sim.board.true_pose.heading == heading


def test_the_thesis_board_refuses_a_turn_with_v_0_as_before():
    sim = board("thesis")
    sim.run("set mode 2", f"set a {A}", "set v 0", "set vg 30")
    assert sim.cmd("set p 1") == "Error: Argument out of range"
    assert sim.board.true_pose.heading == 0.0


def curve(sim: SimBench, twm: bool) -> None:
    sim.run("set r 100", f"set a {A}", "set mode 0")
    if twm:
        assert sim.cmd("set twm 0.3 1.5 0.4 0.35 2.5 0") == ""  # just the prompt
    else:
        sim.run("set vg 0.3", "set cdp 1.5", "set vgr 0.4", "set v 0.35", "set p 2.5")


def test_twm_is_the_same_move_as_separate_sets():
    one, several = board("giraff-x"), board("giraff-x")
    curve(one, twm=True)
    curve(several, twm=False)
    assert (
        one.value("get twm")
        == several.value("get twm")
        == pytest.approx({"vg": 0.3, "cdp": 1.5, "vgr": 0.4, "v": 0.35, "p": 2.5})
    )
    one.advance(3.0)
    several.advance(3.0)
    assert one.board.true_pose == several.board.true_pose
    assert one.bulk() == several.bulk()
    one.run_until_stopped()
    several.run_until_stopped()
    assert one.board.true_pose == several.board.true_pose
    assert one.board.true_pose.heading < -0.1  # it did curve, to the right


@pytest.mark.parametrize("r", [50, 1, 0])
def test_twm_carries_its_own_curvature_whatever_r_was(r):
    # A driver sends its curves with twm after a stop idiom that left r = 50, and the
    # robot still curves (wire-facts "What the deployed drivers do", twm on Giraff-X).
    after_stop, curved = board("giraff-x"), board("giraff-x")
    after_stop.run("set a 0", "set v 0", "set p 0", f"set r {r}", "set vgr 0")
    curve(curved, twm=True)
    after_stop.run(f"set a {A}", "set mode 0")
    assert after_stop.cmd("set twm 0.3 1.5 0.4 0.35 2.5 0") == ""
    for sim in (after_stop, curved):
        sim.run_until_stopped()
    assert after_stop.board.true_pose == curved.board.true_pose
    assert after_stop.board.true_pose.heading < -0.1  # it curved (to the right: vg > 0)
    assert after_stop.value("get r") == r  # the board's r itself is left alone


@pytest.mark.parametrize(
    ("values", "error"),
    [
        ("0.3 1.5 0.4 0.35 2.5", "Error: Argument wasn't optional"),
        ("0.3 1.5 0.4 0.35 2.5 1", "Error: Unknown argument"),
        ("0.3 1.5 0.4 0.35 2.5 0 0", "Error: Unknown argument"),
        ("0.3 1.5 x 0.35 2.5 0", "Error: Unknown argument"),
        ("0.3 1.5 0.4 0.35 1e3 0", "Error: Unknown argument"),
    ],
)
def test_a_malformed_twm_is_refused_and_changes_nothing(values, error):
    sim = board("giraff-x")
    before = sim.cmd("get twm")
    assert sim.cmd(f"set twm {values}") == error
    assert sim.cmd("get twm") == before
    assert not sim.bulk()["mode"] & 128


def start_straight(sim: SimBench) -> None:
    sim.run("set r 1", f"set a {A}", f"set v {V}", "set p 10")
    sim.advance(2.0)  # cruising at 0.4 m/s


@pytest.mark.parametrize("name", ["later", "giraff-x"])
@pytest.mark.parametrize("stop", [("set a 0", "set v 0", "set p 0"), ("set v 0", "set p 0"),
                                  ("set a 0", "set p 1")])  # fmt: skip
def test_later_boards_brake_on_a_zero_speed_at_the_moves_deceleration(name, stop):
    sim = board(name)
    start_straight(sim)
    x = sim.board.true_pose.x
    sim.run(*stop)
    sim.advance(V / A / 2)
    assert sim.bulk()["gvr"] == pytest.approx(V / 2, abs=1e-6)  # still braking, not stopped
    assert sim.run_until_stopped(step=0.01) == pytest.approx(V / A / 2, abs=0.011)
    assert sim.board.true_pose.x - x == pytest.approx(V * V / (2 * A), abs=1e-6)


def test_a_brake_drops_the_queued_moves_and_stops_a_rotation_too():
    sim = board("later")
    sim.run("set r 0", f"set a {A}", f"set v {V}", "set p 360", "set mode 4", "set p 90")
    sim.advance(2.0)  # turning at 0.4 wheel metres a second
    turned = -sim.bulk()["cang"]
    sim.run("set v 0", "set p 0")
    sim.run_until_stopped()
    braked = V * V / (2 * A) * TURN_FACTOR_DEG_PER_M
    assert -sim.bulk()["cang"] == pytest.approx(turned + braked, abs=1e-4)
    sim.advance(10.0)
    assert -sim.bulk()["cang"] == pytest.approx(turned + braked, abs=1e-4)  # no 90 after it


def test_a_zero_speed_brake_at_rest_is_accepted_and_does_nothing():
    sim = board("later")
    assert sim.cmd("set a 0") == "F*00000000"
    assert sim.cmd("set p 0") == "F*00000000"
    assert sim.board.true_pose.x == 0.0


def test_the_thesis_board_refuses_a_zero_speed_and_carries_on():
    sim = board("thesis")
    start_straight(sim)
    assert sim.cmd("set a 0") == "F*00000000"
    assert sim.cmd("set p 0") == "Error: Argument out of range"
    sim.run_until_stopped()
    assert sim.board.true_pose.x == pytest.approx(10.0)


@pytest.mark.parametrize("name", ["thesis", "later"])
def test_the_true_pose_turns_by_the_real_wheel_base(name):
    sim = board(name, wheel_base=0.467)
    sim.run("set r 0", f"set a {A}", f"set v {V}", "set p 90")
    sim.run_until_stopped()
    # The board counts by its own geometry, the robot turns by its own.
    assert sim.bulk()["cang"] == -90.0
    expected = -math.radians(90) * WHEEL_BASE_M / 0.467
    assert sim.board.true_pose.heading == pytest.approx(expected, abs=1e-9)


ROS1_STOP = ("set a 0", "set v 0", "set p 0", "set r 50", "set vgr 0")
ROS2_IDLE = ("set v 0", "set vg 0", "set p 0")
MOVES = {
    "straight": ("set mode 0", "set r 1", f"set a {A}", f"set v {V}", "set p 10"),
    "rotation": ("set mode 0", "set r 0", f"set a {A}", f"set v {V}", "set p 720"),
    "curve": ("set mode 0", "set r 100", f"set a {A}", f"set v {V}", "set vg 0.2", "set vgr 0.4",
              "set cdp 8", "set p 10"),
    "mode 2 curve": ("set mode 2", f"set a {A}", f"set v {V}", "set vg 20", "set p 1"),
    "mode 2 spin": ("set mode 2", f"set a {A}", "set v 0", "set vg 30", "set p 1"),
}  # fmt: skip


@pytest.mark.parametrize("name", ["later", "giraff-x"])
@pytest.mark.parametrize("move", MOVES)
@pytest.mark.parametrize("stop", [ROS1_STOP, ROS2_IDLE], ids=["ros1 stop", "ros2 idle"])
def test_the_drivers_stop_idioms_are_answered_and_stop_every_kind_of_move(name, move, stop):
    # Both drivers stop with set a 0 / set v 0 / set p 0 (wire-facts "Stopping"); a
    # zero acceleration must never divide by zero, be refused, or leave the robot moving.
    sim = board(name)
    sim.run(*MOVES[move])
    sim.advance(1.5)
    for command in stop:
        reply = sim.cmd(command)
        assert "rror" not in reply and "Unknown" not in reply, (command, reply)
    assert sim.run_until_stopped(step=0.01) <= V / A + 0.02  # braked at a, not dropped
    pose = sim.board.true_pose
    sim.advance(10.0)
    assert sim.board.true_pose == pose


@pytest.mark.parametrize("name", ["later", "giraff-x"])
def test_a_move_asked_for_with_a_0_never_starts(name):
    # What a zero acceleration means to a real board is undocumented: the safe reading
    # is a stop, so a driver that left a = 0 after its stop idiom does not set off.
    sim = board(name)
    sim.run("set a 0", "set r 1", f"set v {V}", "set p 1")
    sim.run("set mode 2", "set vg 30", "set p 1")
    sim.run("set v 0", "set p 1")
    sim.advance(5.0)
    assert sim.board.true_pose == TruePose()
