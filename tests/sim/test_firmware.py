"""Firmware profiles: what a later board answers that the thesis's does not (wire-facts,
"Later firmware, as real drivers use it")."""

from __future__ import annotations

import math
import struct

import pytest
import serial

import giraff_console  # noqa: F401  (registers giraff-sim://)
from giraff_console.protocol.charger import PARAMETERS, ChargeStatus, parse_charger
from giraff_console.protocol.kinematics import WHEEL_BASE_M
from giraff_console.sim import BoardConfig, HomingState
from giraff_console.sim.firmware import FIRMWARES
from giraff_console.sim.odometers import ENCODER_COUNTS_PER_M
from tests.conftest import SimBench


def board(name: str, **config) -> SimBench:
    return SimBench(BoardConfig(firmware=FIRMWARES[name], **config))


@pytest.mark.parametrize(
    ("name", "banner"),
    [
        ("thesis", b"# Giraf 1.1.112p-sim, 2013-06-01\r\n"),
        ("later", b"# Giraf 1.4.226-sim, 2015-09-14\r\n"),
        ("giraff-x", b"# Giraf X2.0.9-sim, 2017-03-02\r\n"),
    ],
)
def test_the_banner_tells_the_profiles_apart(name, banner):
    assert board(name).board.greeting() == banner + b"OK >\r\n"


def test_the_default_is_the_thesis_board():
    assert SimBench().board.firmware is FIRMWARES["thesis"]


LATER_COMMANDS = ["get enc0", "set enc1 0", "get h", "set h 10", "get charger_data", "get twm",
                  "set twm 0 0 0 0.3 1 0"]  # fmt: skip


@pytest.mark.parametrize("command", LATER_COMMANDS)
def test_the_thesis_board_knows_none_of_the_later_names(command):
    name = command.split()[1]
    assert board("thesis").cmd(command) == f"Unknown name: {name}"


def test_only_giraff_x_knows_twm():
    later = board("later")
    assert later.cmd("get twm") == "Unknown name: twm"
    assert later.cmd("set twm 0 0 0 0.3 1 0") == "Unknown name: twm"
    assert board("giraff-x").cmd("get twm").startswith("vg:F*")


def drive_curve(sim: SimBench, read_every: float, seconds: float) -> list[dict]:
    """A curve then a turn in place, reading bulk_data every `read_every` seconds."""
    sim.run("set r 100", "set a 0.5", "set v 0.4", "set vg 0.3", "set vgr 0.5",
            "set cdp 2", "set p 3")  # fmt: skip
    readings = []
    for step in range(round(seconds / read_every)):
        sim.advance(read_every)
        readings.append(sim.bulk())
        if step == round(5 / read_every):
            sim.run("set r 0", "set p -60")  # a turn in place, after braking
    return readings


def test_later_odometers_are_increments_a_driver_can_add_up():
    sim = board("later")
    x = y = heading = 0.0
    for bulk in drive_curve(sim, 0.05, 20.0):
        # The ROS 2 driver's integration (wire-facts "Later firmware").
        left, right = bulk["imdl"], bulk["imdr"]
        turn = (right - left) / WHEEL_BASE_M
        mid = heading + turn / 2
        x += (left + right) / 2 * math.cos(mid)
        y += (left + right) / 2 * math.sin(mid)
        heading += turn
    truth = sim.board.true_pose
    assert abs(truth.heading) > 0.5 and math.hypot(truth.x, truth.y) > 1.5  # it did move
    assert math.hypot(x - truth.x, y - truth.y) < 1e-4
    assert heading == pytest.approx(truth.heading, abs=1e-5)


def test_a_read_resets_the_increments():
    sim = board("later")
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.advance(1.0)
    assert sim.bulk()["imdl"] > 0
    again = sim.bulk()
    assert (again["imdl"], again["imdr"]) == (0.0, 0.0)


def test_increments_add_up_to_the_wheels_travel_without_drifting():
    sim = board("giraff-x")
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 10")
    left = right = 0.0
    for _ in range(3000):  # tiny increments, each rounded to a float32 on the wire
        sim.advance(0.01)
        bulk = sim.bulk()
        left, right = left + bulk["imdl"], right + bulk["imdr"]
    assert left == pytest.approx(10.0, abs=1e-5)
    assert right == pytest.approx(10.0, abs=1e-5)


def test_the_thesis_board_reports_totals_since_power_up():
    sim = board("thesis")
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.run_until_stopped()
    assert sim.bulk()["imdl"] == sim.bulk()["imdl"] == 1.0


def encoders(sim: SimBench) -> tuple[int, int]:
    return sim.value("get enc0"), sim.value("get enc1")


def test_encoders_count_each_wheel():
    sim = board("later")
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.run_until_stopped()
    counts = math.floor(ENCODER_COUNTS_PER_M)
    assert encoders(sim) == (counts, counts)
    sim.run("set r 0", "set p 90")  # in place: the left wheel forwards, the right back
    sim.run_until_stopped()
    wheel = 90 * math.pi / 180 * WHEEL_BASE_M / 2
    assert encoders(sim) == (
        math.floor((1 + wheel) * ENCODER_COUNTS_PER_M),
        math.floor((1 - wheel) * ENCODER_COUNTS_PER_M),
    )


def test_encoders_wrap_at_16_bits_both_ways():
    sim = board("later")
    sim.run("set enc0 65000", "set r 1", "set a 0.5", "set v 0.4", "set p 1")
    sim.run_until_stopped()
    assert encoders(sim) == ((65000 + 2002) % 65536, 2002)
    sim.run("set p -2")
    sim.run_until_stopped()
    assert encoders(sim)[1] == 65536 + math.floor(-1 * ENCODER_COUNTS_PER_M)


def test_setting_an_encoder_keeps_the_fraction_of_a_count():
    sim = board("later")
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 0.0003")  # 0.6 of a count
    sim.run_until_stopped()
    sim.run("set enc0 0", "set enc1 100")
    assert encoders(sim) == (0, 100)
    sim.run("set p 0.0003")  # with the 0.6 kept, 1.2 counts: one more
    sim.run_until_stopped()
    assert encoders(sim) == (1, 101)


@pytest.mark.parametrize("value", ["-1", "65536", "70000"])
def test_an_encoder_beyond_16_bits_is_refused(value):
    assert board("later").cmd(f"set enc0 {value}") == "Error: Argument out of range"


def test_the_stalk_moves_to_its_height_at_a_finite_speed():
    sim = board("later")
    assert sim.cmd("get h") == "I*00000000"
    assert sim.cmd("set h 1000") == "I*e8030000"
    sim.advance(2.0)
    assert sim.value("get h") == 500
    sim.advance(2.5)
    assert sim.value("get h") == 1000
    sim.run("set h 250")
    sim.advance(1.0)
    assert sim.value("get h") == 750


@pytest.mark.parametrize("value", ["-1", "1001", "5000"])
def test_the_stalk_refuses_heights_out_of_its_range(value):
    sim = board("giraff-x")
    assert sim.cmd(f"set h {value}") == "Error: Argument out of range"
    sim.advance(5.0)
    assert sim.value("get h") == 0


def test_charger_data_gives_one_parameter_per_read_in_turn():
    sim = board("later")
    readings = [parse_charger(sim.cmd("get charger_data")) for _ in range(12)]
    assert [reading.parameter for reading in readings] == list(PARAMETERS) * 2
    assert {reading.status for reading in readings} == {ChargeStatus.NOT_DOCKED}
    values = {reading.parameter: reading.value for reading in readings[:6]}
    assert values["B"] == pytest.approx(25.6, abs=0.01)  # full
    assert values["b"] < 0  # discharging
    assert values["t"] == pytest.approx(25.0)
    assert (values["D"], values["d"], values["W"]) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("name", ["later", "giraff-x"])
def test_every_charger_parameter_is_sent_as_a_float_w_included(name):
    # Both deployed drivers read `W:F#<hex>` and recognise nothing else (wire-facts "What
    # the deployed drivers do", Battery): one never gets a level from `W:I#`.
    sim = board(name, battery=0.75)
    sim.advance(10.0)
    lines = [sim.cmd("get charger_data") for _ in PARAMETERS]
    assert [line.split(",")[1][:4] for line in lines] == [f"{p}:F#" for p in PARAMETERS]
    (w_line,) = [line for line in lines if ",W:" in line]
    drawn = struct.unpack("<f", bytes.fromhex(w_line.split("#")[2][:8]))[0]
    c = -327_360.0  # the driver's constant and formula: level = |(c - W) / c|
    assert abs((c - drawn) / c) == pytest.approx(sim.board.battery_level, abs=1e-6)


def open_port(query: str) -> serial.SerialBase:
    return serial.serial_for_url(f"giraff-sim://?clock=virtual{query}", timeout=0.5)


def test_url_options_choose_the_firmware_battery_and_wheel_base():
    port = open_port("&firmware=giraff-x&battery=0.3&wheel_base=0.467")
    assert port.board.firmware is FIRMWARES["giraff-x"]
    assert port.board.battery_level == pytest.approx(0.3)
    assert port.board.config.wheel_base == 0.467
    assert open_port("").board.firmware is FIRMWARES["thesis"]


@pytest.mark.parametrize(
    ("query", "why"),
    [
        ("&firmware=2015", "firmware must be one of thesis, later, giraff-x"),
        ("&battery=1.5", "battery must be a number from 0 to 1"),
        ("&battery=full", "battery must be a number from 0 to 1"),
        ("&wheel_base=0", "wheel_base must be a number from 0.2 to 1"),
        ("&wheel_base=nan", "wheel_base must be a number"),
    ],
)
def test_bad_firmware_options_are_refused_clearly(query, why):
    with pytest.raises(serial.SerialException, match=why):
        open_port(query)


def test_the_stalk_keeps_its_height_when_the_board_loses_power():
    sim = board("later")
    sim.run("set h 400")
    sim.advance(1.0)
    sim.board.power_off()
    sim.advance(5.0)
    assert sim.value("get h") == 250


@pytest.mark.parametrize("name", ["later", "giraff-x"])
def test_later_boards_home_the_head_by_themselves_at_power_up(name):
    # Boards home by themselves at power-up (A.4.10); neither deployed driver sends
    # `home`, and one waits for tilt_homing_state = 3 (wire-facts "Tilt before homing").
    sim = board(name)
    assert sim.value("get tilt_homing_state") == HomingState.HOMING
    sim.advance(3.0)  # the homing sequence
    assert sim.value("get tilt_homing_state") == HomingState.DONE
    sim.run("set tilt_angle_from_home 0.6")
    sim.advance(2.0)  # at 0.5 rad/s from home
    assert sim.value("get tilt_angle_from_home") == pytest.approx(0.6, abs=1e-6)


@pytest.mark.parametrize("name", ["later", "giraff-x"])
def test_a_later_board_homes_again_after_a_power_cut(name):
    sim = board(name)
    sim.advance(5.0)
    sim.board.power_off()
    assert sim.value("get tilt_homing_state") == HomingState.HOMING


def test_the_thesis_board_still_waits_to_be_told_to_home():
    sim = board("thesis")
    sim.advance(5.0)
    assert sim.value("get tilt_homing_state") == HomingState.NOT_STARTED
    sim.run("set tilt_angle_from_home 0.6")  # before homing: lands wrong (A.4.12)
    sim.advance(5.0)
    assert sim.value("get tilt_angle_from_home") == pytest.approx(0.95, abs=1e-6)
