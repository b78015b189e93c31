"""The limits every command meets: a move's acceleration must stop the robot within the
runaway limit from the fastest it may be going."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from giraff_console.protocol import Command, CommandError, format_number, parse_command
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, TURN_RADIUS_M
from giraff_console.robot.command_guard import (
    CLAMPED,
    READINGS,
    REFUSED_SETTINGS,
    SETTINGS,
    braking_accel,
    check_command,
    check_line,
    clamp_command,
    setting_bounds,
)
from giraff_console.robot.teleop import DriveLimits, Teleop
from giraff_console.sim.board import BoardConfig
from giraff_console.sim.firmware import FIRMWARES
from tests.conftest import SimBench

LIMITS = DriveLimits()
BOARD = {"r": "1000", "mode": "0", "v": "0.4", "vg": "0", "a": "0.5"}


def test_without_the_speed_an_acceleration_must_stop_the_robot_from_top_speed():
    with pytest.raises(CommandError, match="a must be in"):
        check_command(Command("set", "a", 0.2), LIMITS, BOARD)
    check_command(Command("set", "a", LIMITS.min_accel), LIMITS, BOARD)


def test_knowing_the_speed_a_gentler_acceleration_is_allowed_at_low_speed():
    # At 0.1 m/s the robot stops within design.md's 0.3 m at 1/60 m/s^2.
    check_command(Command("set", "a", 0.02), LIMITS, BOARD, speed=0.1)
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.01), LIMITS, BOARD, speed=0.1)
    # And not at cruising speed.
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.2), LIMITS, BOARD, speed=0.4)


def test_a_move_is_checked_against_the_acceleration_the_board_holds():
    gentle = BOARD | {"a": "0.021"}
    check_command(Command("set", "p", 0.24), LIMITS, gentle, speed=0.1)
    with pytest.raises(CommandError):
        check_command(Command("set", "p", 0.24), LIMITS, gentle, speed=0.3)
    with pytest.raises(CommandError, match="p beyond"):
        check_command(Command("set", "p", 0.26), LIMITS, BOARD, speed=0.0)


@pytest.mark.parametrize("speed", [0.0, 1e-5])
def test_a_zero_acceleration_is_never_allowed(speed):
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.0), LIMITS, BOARD, speed=speed)


def test_the_braking_acceleration_stops_the_robot_at_the_runaway():
    accel = braking_accel(0.4, 0.3)
    assert 0.4**2 / (2 * accel) == pytest.approx(0.3)


# -- one guard for every path to the board (issue 12) ------------------------------------


def refusal(text: str, board: dict[str, str] = BOARD) -> str | None:
    """Why the guard refuses a typed line, or None if it lets it through."""
    try:
        check_command(parse_command(text), LIMITS, board)
    except CommandError as error:
        return str(error)
    return None


def test_names_are_checked_whatever_their_case():
    assert parse_command("SET P 5") == Command("set", "p", 5)
    assert "p beyond" in refusal("set P 5")
    assert "v must be" in refusal("Set V 0.6")
    assert refusal("GET BULK_DATA") is None
    # A command built in code is checked as it is written, so as it would be sent.
    with pytest.raises(CommandError, match="no setting called 'P'"):
        check_command(Command("set", "P", 0.1), LIMITS, BOARD)


def test_home_is_the_only_bare_command():
    assert refusal("home") is None
    assert refusal("HOME") is None
    for text in ("reset", "stop", "undock", "anything"):
        assert "only bare command is home" in refusal(text)


@pytest.mark.parametrize(
    "text",
    ["set vgr 2.01", "set vgr -3", "set cdp 0.26", "set cdp -1", "set r -1", "set r 1000.5",
     "set r 100000", "set vg 0.51", "set vg -0.51", "set mode 1", "set mode 0.5",
     "set tilt_angle_from_home 3", "set tilt_angle_from_home 0", "set h 1001", "set h 1.5",
     "set enc0 7", "set v -0.1", "set v 0.41", "set a 0.6", "set p 58", "set mode 2.5",
     "set mode 4"],
)  # fmt: skip
def test_every_setting_has_bounds(text):
    assert refusal(text, BOARD | {"r": "0"} if text == "set p 58" else BOARD)


@pytest.mark.parametrize(
    "text",
    ["set vgr 2", "set vgr -1", "set vgr 0", "set cdp 0.24", "set cdp -0.25", "set r 0",
     "set r 1", "set r 1000", "set vg -0.5", "set mode 0", "set tilt_angle_from_home 1",
     "set h 1000", "set enc1 0", "set v 0.05", "set a 0.5", "set p -0.25", "set v 0",
     "set mode 2"],
)  # fmt: skip
def test_values_within_the_bounds_pass(text):
    assert refusal(text) is None


def test_a_rotation_may_turn_as_far_as_the_reach_in_wheel_travel():
    rotating = BOARD | {"r": "0"}
    assert refusal("set p 57", rotating) is None
    assert "p beyond 57 degrees" in refusal("set p 58", rotating)


def test_the_bounds_cover_every_setting_the_board_takes():
    # p and twm are moves, checked as such.
    assert {*setting_bounds(LIMITS), "p", "twm", *REFUSED_SETTINGS} == SETTINGS
    assert all(bound.why for bound in setting_bounds(LIMITS).values())


@pytest.mark.parametrize("name", ["nonsense", "xyz", "twmm"])
def test_unknown_names_are_refused(name):
    assert "no setting called" in refusal(f"set {name} 0")
    assert "no reading called" in refusal(f"get {name}")


@pytest.mark.parametrize("name", sorted(READINGS))
def test_every_reading_may_be_read(name):
    assert refusal(f"get {name}") is None


@pytest.mark.parametrize("value", ["-0.3", "0.3", "0.01", "-5"])
def test_the_board_s_own_undock_is_refused(value):
    assert "undock is refused" in refusal(f"set undock {value}")


def test_a_line_longer_than_the_board_s_is_refused():
    line = "get " + "x" * 100_000
    assert "longer than the board's line" in refusal(line)
    with pytest.raises(CommandError):
        check_line(parse_command(line))
    check_line(parse_command("set tilt_angle_from_home -123456789.123456789"))


def test_the_value_checked_is_the_value_sent():
    # 0.5099999999999 goes on the wire as 0.51, at the gear ratio's limit.
    assert "vg must be" in refusal("set vg 0.5099999999999")


def test_zero_speed_is_a_setting_but_not_a_move_in_mode_0():
    """`set v 0` is one of the deployed drivers' stop idioms (wire-facts)."""
    assert refusal("set v 0") is None
    assert "v must be above 0" in refusal("set p 0.1", BOARD | {"v": "0"})


# -- later boards' mode 2 (wire-facts; issue 27) ------------------------------------------

VELOCITY = {"mode": "2", "v": "0.3", "vg": "0", "a": "0.5"}


def test_in_mode_2_vg_is_degrees_per_second_and_r_is_not_needed():
    assert refusal("set vg 28.6", VELOCITY) is None  # 0.5 rad/s, as a driver sends it
    assert refusal("set vg -90", VELOCITY) is None
    assert "vg must be in [-90, 90] degrees/s" in refusal("set vg 91", VELOCITY)
    # In mode 0 the same value is a gear ratio far beyond the thesis's limit.
    assert "vg must be" in refusal("set vg 28.6")
    assert refusal("set p 0.25", VELOCITY) is None
    assert "p beyond 0.25 m" in refusal("set p 1", VELOCITY)  # the driver's renewed p = 1


def test_a_mode_2_curve_reaches_as_far_on_its_outer_wheel_and_keeps_below_0_51():
    # 28.6 degrees/s at 0.3 m/s: a gear ratio of 0.416, the outer wheel 1.416 times as far.
    curving = VELOCITY | {"vg": "28.6"}
    assert refusal("set p 0.17", curving) is None
    assert "on the outer wheel" in refusal("set p 0.2", curving)
    # 28.6 degrees/s at 0.1 m/s would be a gear ratio of 1.25.
    assert "below 0.51" in refusal("set p 0.1", curving | {"v": "0.1"})


def test_a_mode_2_turn_on_the_spot_moves_each_wheel_by_p_within_the_reach():
    spinning = VELOCITY | {"v": "0", "vg": "30"}
    assert refusal("set p 0.25", spinning) is None
    assert refusal("set p -0.25", spinning) is None
    assert "p beyond 0.25 m of each wheel" in refusal("set p 1", spinning)
    assert "needs v above 0, or vg" in refusal("set p 0.1", VELOCITY | {"v": "0"})


def test_a_twm_in_mode_2_is_refused():
    assert "mode 2" in refusal("set twm 0.3 0.2 1 0.25 0.1 0", CURVE | {"mode": "2"})


def test_the_console_s_own_settings_pass():
    teleop = Teleop(LIMITS)
    board: dict[str, str] = {}
    for command in teleop.safe_settings():
        check_command(command, LIMITS, board)
        board.update(command.settings)
    check_command(Command("set", "p", LIMITS.reach), LIMITS, board)


def _set(name: str, values: st.SearchStrategy) -> st.SearchStrategy[str]:
    return st.builds(lambda value: f"set {name} {value}", values)


# Lines that set each move setting near and beyond its bounds, so that moves are often
# accepted; and any name the board takes or not, in any case, with any value.
_ANY_VALUE = st.one_of(
    st.floats(-1000, 1000, allow_nan=False), st.integers(-(10**10), 10**10),
    st.sampled_from([0, 1, -1, 0.25, -0.25, 0.4, 0.32, 0.5, 0.51, 57, -57.4, 1000]),
)  # fmt: skip
# Giraff-X's whole curved move (wire-facts): vg cdp vgr v p, then 0 or not; values with
# four decimals, as the console writes them, so that they fit the line.
_TWM = st.builds(
    lambda *values: "set twm " + " ".join(f"{value:.4f}" for value in values),
    st.floats(-0.55, 0.55),
    st.floats(-0.27, 0.27),
    st.floats(-2.2, 2.2),
    st.floats(0, 0.42),
    st.floats(-0.3, 0.3),
    st.sampled_from([0, 0, 0, 1]),
)
_LINE = st.one_of(
    _set("r", st.sampled_from([0, 1, 50, 51, 1000, -1, 1001])),
    _set("mode", st.sampled_from([0, 0, 1, 2, 4])),
    _set("v", st.floats(0, 0.45)),
    _set("a", st.floats(0.25, 0.6)),
    _set("vg", st.floats(-0.6, 0.6)),
    _set("vg", st.floats(-100, 100)),  # degrees per second, in mode 2
    _set("vgr", st.floats(-2.5, 2.5)),
    _set("cdp", st.floats(-0.3, 0.3)),
    _set("p", st.floats(-0.3, 0.3)),
    _set("p", st.floats(-70, 70)),
    st.builds(lambda name, value: f"set {name} {value}",
              st.sampled_from(sorted(SETTINGS | {"P", "V", "Mode", "twm", "xyz"})), _ANY_VALUE),
    _TWM,
)  # fmt: skip
# Mostly after settings that let a move go, in any order; sometimes from the board's own.
_SETUP = st.one_of(
    st.just([]),
    st.tuples(
        _set("r", st.sampled_from([0, 1, 1000])), st.just("set mode 0"),
        _set("v", st.floats(0.01, 0.4)), _set("a", st.floats(0.32, 0.5)),
        _set("vg", st.floats(-0.5, 0.5)),
    ).flatmap(st.permutations),
)  # fmt: skip
_LINES = st.one_of(
    st.builds(lambda setup, lines: [*setup, *lines], _SETUP,
              st.lists(_LINE, min_size=1, max_size=9)),
    # Or on a curve with all a twm needs, with twms among the lines (Giraff-X).
    st.builds(lambda accel, lines: ["set r 1000", "set mode 0", f"set a {accel}", *lines],
              st.floats(0.32, 0.5), st.lists(_TWM | _LINE, min_size=1, max_size=9)),
    # Or in later boards' mode 2, as the deployed drivers drive (wire-facts): curving at
    # vg degrees per second, or turning on the spot with v = 0.
    st.builds(lambda setup, lines: [*setup, *lines],
              st.tuples(st.just("set mode 2"), _set("a", st.floats(0.32, 0.5)),
                        _set("v", st.sampled_from([0.0]) | st.floats(0.05, 0.4)),
                        _set("vg", st.floats(-100, 100) | st.floats(-15, 15)),
                        ).flatmap(st.permutations),
              st.lists(_LINE, min_size=1, max_size=9)),
)  # fmt: skip


def _accepted(text: str, board: dict[str, str]) -> Command | None:
    try:
        command = parse_command(text)
        check_command(command, LIMITS, board)
    except CommandError:
        return None
    board.update(command.settings)
    return command


@settings(max_examples=2000, deadline=None)
@given(_LINES)
def test_no_accepted_line_puts_a_target_beyond_the_reach(lines):
    board: dict[str, str] = {}
    for text in lines:
        command = _accepted(text, board)
        if command is None or command.name not in ("p", "twm"):
            continue
        target, vg, speed = float(board["p"]), float(board["vg"]), float(board["v"])
        if float(board["mode"]) == 2:
            # Turning on the spot by p metres of each wheel, or curving at the gear ratio
            # that turns at vg degrees per second at v (sim/move.py).
            gear = math.radians(abs(vg)) / speed * TURN_RADIUS_M if speed else 0.0
            assert gear < 0.51
            reach = target * (1 + gear)
        elif command.name == "twm":  # a curve whatever r (wire-facts)
            reach = target * (1 + abs(vg))
        else:
            style = float(board["r"])
            # On the outer wheel in a curve (A.2.3), in wheel metres turning on the spot.
            outer = 1 + abs(vg) if style > 50 else 1.0
            reach = target / TURN_FACTOR_DEG_PER_M if style <= 0 else target * outer
        assert abs(reach) <= LIMITS.reach + 1e-9
        # And the board will brake from any speed it may have within that distance.
        assert float(board["v"]) <= LIMITS.max_speed
        assert LIMITS.max_speed**2 / (2 * float(board["a"])) <= LIMITS.reach + 1e-9


@settings(max_examples=150, deadline=None)
@given(_LINES, st.lists(st.floats(0, 1.5), min_size=14, max_size=14))
def test_after_the_last_accepted_line_the_robot_stays_within_the_reach(lines, gaps):
    """On the simulator, measured with its true pose: whatever was accepted, and however
    the robot was moving when the last command went out, it then stops within the
    console's reach (wheel travel, when it turns on the spot). The board is Giraff-X, so
    that a twm accepted is driven too (on the others it is an unknown name)."""
    sim = SimBench(BoardConfig(firmware=FIRMWARES["giraff-x"]))
    board = {name: format_number(sim.value(f"get {name}")) for name in ("r", "v", "a", "vg")}
    sent: list[tuple[Command, float]] = []  # and the time until the next one
    for text, gap in zip(lines, gaps, strict=False):
        command = _accepted(text, board)
        if command is not None:
            sent.append((command, gap))
            # Moves at under 1 cm/s take too long to watch; the reach does not
            # depend on the speed.
            assume(command.name not in ("p", "twm") or float(board["v"]) >= 0.01)
        elif sent:
            sent[-1] = (sent[-1][0], sent[-1][1] + gap)
    for index, (command, gap) in enumerate(sent):
        assert "rror" not in sim.cmd(command.text)
        if index < len(sent) - 1:
            sim.advance(gap)
    # Then the console dies: the robot is watched from where it is now.
    start = sim.board.true_pose
    farthest = turned = 0.0
    for _ in range(4000):
        pose = sim.board.true_pose
        farthest = max(farthest, math.hypot(pose.x - start.x, pose.y - start.y))
        turn = (pose.heading - start.heading + math.pi) % (2 * math.pi) - math.pi
        turned = max(turned, abs(turn))
        if not sim.bulk()["mode"] & 128:
            break
        sim.advance(0.01)
    else:
        pytest.fail("the robot never stopped")
    assert farthest <= LIMITS.reach + 1e-3
    assert turned * TURN_RADIUS_M <= LIMITS.reach + 1e-3


# -- Giraff-X's twm: checked as the move it is (issue 13) --------------------------------

CURVE = BOARD | {"vgr": "1", "cdp": "0"}


def test_a_twm_within_the_bounds_on_a_curve_passes():
    assert refusal("set twm 0.3 0.2 1 0.25 0.15 0", CURVE) is None
    assert refusal("set twm -0.5 -0.25 -2 0.4 0.16 0", CURVE) is None


@pytest.mark.parametrize(
    ("text", "why"),
    [("set twm 0.51 0.2 1 0.25 0.1 0", "vg must be"), ("set twm 0.3 0.26 1 0.25 0.1 0",
     "cdp must be"), ("set twm 0.3 0.2 2.1 0.25 0.1 0", "vgr must be"),
     ("set twm 0.3 0.2 1 0.41 0.1 0", "v must be"), ("set twm 0.3 0.2 1 0 0.1 0", "v must be"),
     ("set twm 0.3 0.2 1 0.000000000001 0.1 0", "v must be")],
)  # fmt: skip
def test_each_value_of_a_twm_is_within_its_own_setting_s_bounds(text, why):
    assert why in refusal(text, CURVE)


@pytest.mark.parametrize("end", ["1", "-1", "0.5", "0.000001"])
def test_a_twm_ends_in_zero(end):
    assert "ends in 0" in refusal(f"set twm 0.3 0.2 1 0.25 0.1 {end}", CURVE)


@pytest.mark.parametrize("style", ["0", "1", "50", "1000"])
def test_a_twm_is_a_curve_whatever_the_board_s_r(style):
    """A driver leaves r = 50 after its stop idiom and its twm still curves (wire-facts,
    "What the deployed drivers do"): checked on the outer wheel all the same."""
    board = CURVE | {"r": style}
    assert refusal("set twm 0.3 0.2 1 0.25 0.1 0", board) is None
    assert "on the outer wheel" in refusal("set twm 0.5 0.2 1 0.25 0.2 0", board)


def test_a_twm_does_not_need_r():
    board = {name: text for name, text in CURVE.items() if name != "r"}
    assert refusal("set twm 0.3 0.2 1 0.25 0.1 0", board) is None


@pytest.mark.parametrize("unknown", ["a", "mode"])
def test_a_twm_needs_what_it_does_not_carry_to_be_known(unknown):
    board = {name: text for name, text in CURVE.items() if name != unknown}
    assert f"the board's {unknown} is unknown" in refusal("set twm 0.3 0.2 1 0.25 0.1 0", board)


def test_a_twm_needs_only_what_it_does_not_carry():
    # vg and v are the twm's own: the board's are not needed, nor checked.
    board = {"r": "1000", "mode": "0", "a": "0.5"}
    assert refusal("set twm 0.3 0.2 1 0.25 0.1 0", board) is None
    assert refusal("set twm 0.3 0.2 1 0.25 0.1 0", board | {"v": "7", "vg": "0.9"}) is None
    assert "a must be" in refusal("set twm 0.3 0.2 1 0.25 0.1 0", board | {"a": "0.1"})
    assert "mode must be" in refusal("set twm 0.3 0.2 1 0.25 0.1 0", board | {"mode": "1"})


def test_a_twm_s_reach_is_on_the_outer_wheel_of_its_own_gear_ratio():
    # 0.2 m ahead with vg 0.5: the outer wheel goes 0.3 m, beyond the 0.25 m reach, though
    # the board's own vg (0) would let a `set p 0.2` go.
    assert refusal("set p 0.2", CURVE) is None
    assert "on the outer wheel" in refusal("set twm 0.5 0.2 1 0.25 0.2 0", CURVE)
    assert "on the outer wheel" in refusal("set twm -0.5 0.2 -1 0.25 -0.2 0", CURVE)
    assert refusal("set twm 0.5 0.16 1 0.25 0.16 0", CURVE) is None
    # And the other way: a straighter twm may reach further than the board's vg allows.
    bent = CURVE | {"vg": "0.5"}
    assert "p beyond" in refusal("set p 0.24", bent)
    assert refusal("set twm 0 0 1 0.25 0.24 0", bent) is None


def test_a_twm_s_acceleration_must_stop_the_robot_from_the_speed_it_may_have():
    gentle = CURVE | {"a": "0.021"}
    twm = parse_command("set twm 0.3 0.1 1 0.1 0.1 0")
    check_command(twm, LIMITS, gentle, speed=0.1)
    with pytest.raises(CommandError, match="a must be"):
        check_command(twm, LIMITS, gentle, speed=0.3)


def test_a_twm_longer_than_the_board_s_line_is_refused():
    longest = "set twm -0.509999999 -0.249999999 -1.999999999 0.399999999 -0.159999999 0"
    assert len(longest) == 73
    assert "longer than the board's line" in refusal(longest, CURVE)
    assert refusal("set twm -0.5 -0.25 -1.9999 0.3999 -0.16 0", CURVE) is None


def test_a_twm_with_the_wrong_number_of_values_is_refused_as_typed():
    assert "usage: set twm vg cdp vgr v p 0" in refusal("set twm 0.3 0.2 1 0.25 0.1", CURVE)
    assert "usage" in refusal("set twm 0", CURVE)


# -- clamped for a program that does not read the reasons (the virtual port, issue 27) ----


def clamped(text: str, board: dict[str, str] = BOARD) -> str:
    return clamp_command(parse_command(text), LIMITS, board).text


@pytest.mark.parametrize(
    ("text", "board", "becomes"),
    [("set a 0.2", BOARD, "set a 0.32"), ("set a 0.6", BOARD, "set a 0.5"),
     ("set vgr 20", BOARD, "set vgr 2"), ("set v 0.6", BOARD, "set v 0.4"),
     ("set vg 28.6", BOARD, "set vg 0.5"), ("set vg 120", VELOCITY, "set vg 90"),
     ("set cdp 1", BOARD, "set cdp 0.25"), ("set p 1", BOARD, "set p 0.25"),
     ("set p -1", BOARD, "set p -0.25"), ("set p -90", BOARD | {"r": "0"}, "set p -57.410600714"),
     ("set p 1", VELOCITY | {"v": "0", "vg": "30"}, "set p 0.25"),
     ("set twm 0.6 1 20 0.6 1 0", CURVE | {"r": "50"}, "set twm 0.5 0.25 2 0.4 0.166666666 0")],
)  # fmt: skip
def test_the_deployed_drivers_values_are_clamped_within_the_limits(text, board, becomes):
    """What the drivers send (wire-facts, "What the deployed drivers do"), brought within
    the limits, and then let through."""
    assert clamped(text, board) == becomes
    assert refusal(becomes, board) is None


@pytest.mark.parametrize(
    ("text", "board"),
    [("set mode 3", BOARD), ("set enc0 5", BOARD), ("set undock 1", BOARD),
     ("set p 1", BOARD | {"v": "0"}), ("set p 0.1", VELOCITY | {"vg": "50", "v": "0.05"}),
     ("set p 1", {"mode": "0"}), ("get v", BOARD), ("home", BOARD)],
)  # fmt: skip
def test_what_cannot_be_made_safe_by_clamping_is_left_for_the_guard_to_refuse(text, board):
    assert clamped(text, board) == parse_command(text).text


@settings(max_examples=1000, deadline=None)
@given(_LINES)
def test_a_clamped_command_is_never_refused_for_what_clamping_brings_within_bounds(lines):
    """Whatever the guard still refuses after clamping, it is not the command's own
    clamped value out of its bounds, nor its target beyond the reach (a setting the board
    already holds may be: clamping changes only what is sent)."""
    board: dict[str, str] = {}
    for text in lines:
        try:
            command = parse_command(text)
        except CommandError:
            continue
        own = {command.name} & CLAMPED if command.kind == "set" else set()
        values = {command.name: command.values[0]} if len(command.values) == 1 else {}
        if command.name == "twm":
            own = {"vg", "cdp", "vgr", "v"}
            values = dict(zip(("vg", "cdp", "vgr", "v"), command.values, strict=False))
        # A negative speed, or an acceleration of 0 or less, is refused, not clamped into
        # another kind of move.
        if float(values.get("v", 0)) < 0:
            own.discard("v")
        if float(values.get("a", 1)) <= 0:
            own.discard("a")
        try:
            command = clamp_command(command, LIMITS, board)
            check_command(command, LIMITS, board)
        except CommandError as error:
            why = str(error)
            if command.name in ("p", "twm"):
                assert not why.startswith("p beyond"), (text, why)
            assert not any(why.startswith(f"{name} must be in") for name in own), (text, why)
            continue
        board.update(command.settings)
