"""The simulated board's command set, head, buttons and presentation (A.3-A.4)."""

from __future__ import annotations

import math

import pytest

from giraff_console.protocol import parse_reply
from giraff_console.sim import HOME_TILT, BoardConfig, HomingState
from giraff_console.sim.line import BoardLine
from tests.conftest import SimBench


def test_greeting_is_the_version_banner_then_the_prompt(sim):
    assert sim.board.greeting() == b"# Giraf 1.1.112p-sim, 2013-06-01\r\nOK >\r\n"


def test_greeting_can_start_with_a_ca_line():
    greeting = SimBench(BoardConfig(calibration_line=True)).board.greeting()
    assert greeting.startswith(b"Ca>\r\n# Giraf ")


@pytest.mark.parametrize("name", ["v", "a", "r", "p", "vg", "vgr", "cdp"])
def test_every_set_has_a_matching_get(sim, name):
    assert sim.cmd(f"set {name} 0.25") == "F*0000803e"
    assert sim.value(f"get {name}") == 0.25


def test_get_of_one_value_is_exactly_18_characters(sim):
    assert len(sim.board.execute("get v")) == 18


def test_mode_is_an_integer_and_only_the_low_bits_are_writable(sim):
    assert sim.cmd("set mode 255") == "I*0f000000"
    assert sim.value("get mode") == 1  # ABSOLUTE reads back; BUFFERED does not


def test_unknown_names_are_reported(sim):
    assert sim.cmd("get xyz") == "Unknown name: xyz"
    assert sim.cmd("set xyz 1") == "Unknown name: xyz"
    assert sim.cmd("dance") == "Unknown name: dance"


def test_argument_errors(sim):
    assert sim.cmd("set v") == "Error: Argument wasn't optional"
    assert sim.cmd("get") == "Error: Argument wasn't optional"
    assert sim.cmd("set v fast") == "Error: Unknown argument"
    assert sim.cmd("set v 1e-5") == "Error: Unknown argument"  # plain decimals only


def test_an_empty_line_gets_just_the_prompt(sim):
    assert sim.board.execute("") == b"OK >\r\n"


def test_individual_readings_match_bulk(sim):
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.advance(1.0)
    bulk = sim.bulk()
    for name in ("cang", "cdis", "gvr", "cvg", "tilt_angle_from_home", "mode"):
        assert sim.value(f"get {name}") == bulk[name]


def test_bulk_data_has_all_eight_fields_in_the_real_order(sim):
    line = sim.cmd("get bulk_data")
    assert [item.split(":")[0] for item in line.split(",")] == [
        "cang", "cdis", "gvr", "tilt_angle_from_home", "imdl", "imdr", "cvg", "mode", "",
    ]  # fmt: skip


def test_bulk_can_drop_the_trailing_comma_as_the_thesis_did():
    sim = SimBench(BoardConfig(list_trailing_comma=False))
    assert not sim.cmd("get bulk_data").endswith(",")


def test_upper_case_hex():
    sim = SimBench(BoardConfig(hex_upper=True))
    assert sim.cmd("set v 0.4") == "F*CDCCCC3E"
    assert sim.value("get v") == pytest.approx(0.4)


@pytest.mark.parametrize(("style", "reply"), [("none", ""), ("labelled", "New Value: F*0000003f")])
def test_set_reply_styles_of_other_firmware(style, reply):
    sim = SimBench(BoardConfig(set_reply=style))
    assert sim.cmd("set a 0.5") == reply
    assert sim.value("get a") == 0.5


def test_homing_goes_from_not_started_through_homing_to_done(sim):
    assert sim.value("get tilt_homing_state") == HomingState.NOT_STARTED
    sim.run("set tilt_angle_from_home 1.0")  # before homing: lands wrong
    sim.advance(5)
    assert sim.value("get tilt_angle_from_home") == pytest.approx(1.35, abs=1e-6)
    assert sim.cmd("home") == ""
    seen = []
    for _ in range(40):
        seen.append(sim.value("get tilt_homing_state"))
        sim.advance(0.1)
    assert seen[0] == HomingState.HOMING
    assert seen[-1] == HomingState.DONE
    assert sorted(set(seen)) == [HomingState.HOMING, HomingState.DONE]
    assert seen.index(HomingState.DONE) == pytest.approx(30, abs=1)  # three seconds
    assert sim.value("get tilt_angle_from_home") == pytest.approx(HOME_TILT, abs=1e-7)


def test_auto_home_starts_homing_at_power_up():
    sim = SimBench(BoardConfig(auto_home=True))
    assert sim.value("get tilt_homing_state") == HomingState.HOMING


def test_tilt_moves_at_the_head_speed_and_stays_in_its_range(sim):
    sim.run("home")
    sim.advance(3)
    sim.run("set tilt_angle_from_home 1.0")
    sim.advance(0.5)
    assert sim.value("get tilt_angle_from_home") == pytest.approx(HOME_TILT + 0.25, abs=1e-6)
    sim.advance(5)
    assert sim.value("get tilt_angle_from_home") == pytest.approx(1.0, abs=1e-6)
    sim.run("set tilt_angle_from_home 9")
    sim.advance(10)
    assert sim.value("get tilt_angle_from_home") == pytest.approx(2.094, abs=1e-6)


def test_buttons_and_dial_count(sim):
    sim.board.press_button(0)
    sim.board.press_button(0)
    sim.board.press_button(1)
    sim.board.turn_dial(-3)
    assert (sim.value("get but0"), sim.value("get but1"), sim.value("get dial")) == (2, 1, -3)
    assert sim.value("get button_data") == {"but0": 2, "but1": 1, "dial": -3}


def test_estop_stops_the_wheels_and_shows_in_mode(sim):
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 5")
    sim.advance(2.0)
    sim.board.set_estop(True)
    x = sim.board.true_pose.x
    assert sim.bulk()["mode"] == 8
    sim.run("set p 1")  # ignored while ESTOP is raised
    sim.advance(2.0)
    assert sim.board.true_pose.x == x
    sim.board.set_estop(False)
    assert sim.bulk()["mode"] == 0


def test_a_stall_freezes_the_odometry_while_the_move_stays_commanded(sim):
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 5")
    sim.advance(2.0)
    sim.board.stall(1.0)
    before = sim.bulk()
    sim.advance(0.9)
    during = sim.bulk()
    assert during["cdis"] == before["cdis"]
    assert during["gvr"] == 0.0
    assert during["mode"] & 128
    sim.advance(0.2)
    assert sim.bulk()["cdis"] > before["cdis"]


def test_power_off_stops_the_robot_and_forgets_settings(sim):
    sim.run("set v 0.3", "set r 1", "set a 0.5", "set p 5")
    sim.advance(2.0)
    sim.board.power_off()
    x = sim.board.true_pose.x
    sim.advance(1.0)
    assert sim.board.true_pose.x == x > 0
    assert sim.value("get v") == pytest.approx(0.6)  # the board's default again
    assert sim.bulk()["imdl"] == 0.0


def test_true_pose_is_never_on_the_wire(sim):
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.advance(5)
    reply = parse_reply([sim.cmd("get bulk_data")]).value
    assert not {"x", "y", "heading"} & set(reply)
    assert math.isclose(sim.board.true_pose.x, 1.0)


def test_values_beyond_float32_are_refused_and_the_board_carries_on(sim):
    assert sim.cmd("set vg " + "4" * 40) == "Error: Argument out of range"
    assert sim.value("get vg") == 1.0


def test_an_overlong_line_is_refused_whole(sim):
    board_line = BoardLine(sim.board, paced=False)
    board_line.receive(b"set v 0." + b"1" * 300 + b"\r", now=0.0)
    board_line.pump(0.0)
    assert board_line.to_host.pop_due(0.0) == b"Error: Line too long\r\nOK >\r\n"
    assert sim.value("get v") == pytest.approx(0.6)  # nothing of it was run


def test_gvr_is_infinite_at_a_gear_ratio_of_one(sim):
    # §3.2.1.4: v / (1 - vg) divides by zero; the board "probably" reports infinity.
    sim.run("set r 1000", "set a 0.5", "set v 0.4", "set vg 1", "set vgr 1", "set cdp 5", "set p 3")
    sim.advance(3.0)
    assert sim.bulk()["cvg"] == 1.0
    assert sim.bulk()["gvr"] == math.inf
