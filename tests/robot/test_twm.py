"""Curves as one `set twm` on Giraff-X (issue 13): combine_moves, and teleop's picture of
the board after a twm."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from giraff_console.link import BoardLink, Exchange
from giraff_console.link.motor_state import MotorState
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol import Command, CommandError, parse_command
from giraff_console.robot.command_guard import MAX_LINE_CHARS, check_command
from giraff_console.robot.deadman import Intent
from giraff_console.robot.teleop import DriveLimits, Teleop
from giraff_console.robot.twm import combine_moves, separate_moves
from giraff_console.sim.drive import TruePose
from tests.missions.site import PLAN, TICK, Site

HELD = {"r": "1000", "mode": "0", "a": "0.5", "v": "0.4", "vg": "0", "vgr": "1", "cdp": "0"}


def batch(*lines: str) -> list[Command]:
    return [parse_command(line) for line in lines]


def texts(commands: list[Command]) -> list[str]:
    return [command.text for command in commands]


def after(commands: list[Command], held: dict[str, str]) -> dict[str, str]:
    """What the board holds once it took `commands`, in order."""
    board = dict(held)
    for command in commands:
        board.update(command.settings)
    return board


def still(moving: bool = False, cdis: float = 0.0) -> MotorState:
    return MotorState(cang=0.0, cdis=cdis, gvr=0.0, speed=0.0, cvg=0.0, tilt=None, imdl=0.0,
                      imdr=0.0, mode=128 if moving else 0, received_at=0.0)  # fmt: skip


def test_a_curve_s_settings_and_target_become_one_twm_after_what_it_does_not_carry():
    commands = batch("set r 1000", "set mode 0", "set a 0.5", "set v 0.27", "set vgr 1",
                     "set vg 0.49", "set cdp 0.11", "set p 0.11")  # fmt: skip
    assert texts(combine_moves(commands, {})) == [
        "set r 1000", "set mode 0", "set a 0.5", "set twm 0.49 0.11 1 0.27 0.11 0",
    ]  # fmt: skip


def test_what_the_batch_does_not_set_is_taken_from_the_board():
    held = HELD | {"vg": "-0.3", "vgr": "-1"}
    assert texts(combine_moves(batch("set cdp 0", "set p 0.05"), held)) == [
        "set twm -0.3 0 -1 0.4 0.05 0"
    ]


def test_the_board_ends_up_holding_the_same_as_after_the_separate_sets():
    commands = batch("set a 0.4", "set vg 0.2", "set v 0.3", "set p 0.1")
    combined = combine_moves(commands, HELD)
    assert len(combined) == 2
    assert after(combined, HELD) == after(commands, HELD)


def test_a_target_renewed_alone_stays_a_set_p():
    assert texts(combine_moves(batch("set p 0.2"), HELD)) == ["set p 0.2"]
    assert texts(combine_moves(batch("set a 0.4", "set p 0.2"), HELD)) == [
        "set a 0.4", "set p 0.2"
    ]  # fmt: skip


@pytest.mark.parametrize(
    "lines",
    [("set vg 0.2", "set v 0.3"), ("set vg 0.2", "set p 0.1", "set v 0.3"), (),
     ("set vg 0.2", "get bulk_data", "set p 0.1"), ("set vg 0.2", "set h 10", "set p 0.1"),
     ("set vg 0.2", "set vg 0.3", "set p 0.1"), ("home", "set vg 0.2", "set p 0.1"),
     ("set twm 0.2 0 1 0.3 0.1 0",), ("set vg 0.2", "set twm 0.2 0 1 0.3 0.1 0")],
)  # fmt: skip
def test_anything_but_move_settings_then_a_target_is_left_as_it_is(lines):
    commands = batch(*lines)
    assert combine_moves(commands, HELD) == commands


@pytest.mark.parametrize("style", ["0", "1", "50", "-1"])
def test_a_move_that_is_not_a_curve_is_left_as_it_is(style):
    commands = batch("set vg 0", "set v 0.3", "set p 0.1")
    assert combine_moves(commands, HELD | {"r": style}) == commands
    # The batch's own style counts, not the board's.
    with_style = batch(f"set r {style}", "set v 0.3", "set p 0.1")
    assert combine_moves(with_style, HELD) == with_style
    curve = batch("set r 51", "set v 0.3", "set p 0.1")
    assert texts(combine_moves(curve, HELD | {"r": style}))[-1] == "set twm 0 0 1 0.3 0.1 0"


@pytest.mark.parametrize("unknown", ["r", "v", "vg", "vgr", "cdp"])
def test_a_value_the_board_s_picture_lacks_leaves_the_batch_as_it_is(unknown):
    held = {name: text for name, text in HELD.items() if name != unknown}
    # The batch sets one of the twm's values, never the unknown one.
    commands = batch("set mode 0", "set vg 0.1" if unknown == "v" else "set v 0.3", "set p 0.1")
    assert combine_moves(commands, held) == commands
    garbled = HELD | {unknown: "x"}
    assert combine_moves(commands, garbled) == commands


def test_a_twm_longer_than_the_board_s_line_is_never_made():
    commands = batch("set vg -0.509999999", "set cdp -0.249999999", "set vgr -1.999999999",
                     "set v 0.399999999", "set p -0.159999999")  # fmt: skip
    assert combine_moves(commands, HELD) == commands
    shorter = combine_moves(batch("set vg -0.5099", "set p -0.1599"), HELD)
    assert len(shorter[-1].text) <= MAX_LINE_CHARS


def test_combining_twice_changes_nothing_more():
    once = combine_moves(batch("set r 1000", "set vg 0.2", "set p 0.1"), HELD)
    assert once[-1].name == "twm"
    assert combine_moves(once, HELD) == once


_SETTING = st.sampled_from(["r", "a", "mode", "vg", "cdp", "vgr", "v"])
_VALUE = st.sampled_from([0, 1, 51, 1000, 0.25, -0.3, 0.123456789, 2, -1])


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(_SETTING, _VALUE), st.floats(-0.3, 0.3),
       st.dictionaries(_SETTING, st.sampled_from(["0", "1000", "0.3", "-1", "51"])))  # fmt: skip
def test_the_combined_batch_leaves_the_board_as_the_separate_sets_would(sets, target, held):
    commands = [*(Command("set", name, value) for name, value in sets.items()),
                Command("set", "p", target)]  # fmt: skip
    combined = combine_moves(commands, held)
    # Never more commands, the move still last, and the settings twm does not carry first.
    assert len(combined) <= len(commands)
    assert combined[-1].name in ("p", "twm")
    assert after(combined, held) == after(commands, held)
    if combined[-1].name == "twm":
        assert combined[:-1] == [c for c in commands if c.name in ("r", "a", "mode")]
        assert float(after(commands, held)["r"]) > 50
        assert len(combined[-1].text) <= MAX_LINE_CHARS


# -- the console's own moves ---------------------------------------------------------------


def drive_batches(teleop: Teleop, intent: Intent) -> list[list[Command]]:
    """Teleop's batches starting a move, renewing it and stopping it, each combined with
    the board's picture as the loop keeps it (every command checked by the guard)."""
    batches = []
    state = still()
    for step in (lambda: teleop.step(intent, state), lambda: teleop.step(intent, state),
                 lambda: teleop.step(None, still(moving=True))):  # fmt: skip
        separate = step()
        combined = combine_moves(separate, teleop.board_settings)
        for command in combined:
            check_command(command, teleop.limits, teleop.board_settings, speed=0.0)
            if command.kind == "set":
                teleop.board_set(command.name, command.text.split(None, 2)[2])
        batches.append(combined)
    return batches


@settings(max_examples=200, deadline=None)
@given(st.floats(0.05, 0.4), st.sampled_from([Intent.FORWARD_LEFT, Intent.FORWARD_RIGHT]))
def test_teleop_s_curves_go_out_as_twm_that_pass_the_guard_and_fit_the_line(speed, intent):
    teleop = Teleop(DriveLimits())
    for command in teleop.safe_settings():
        teleop.board_set(command.name, command.text.split(None, 2)[2])
    teleop.set_speed(speed)
    start, renew, stop = drive_batches(teleop, intent)
    assert start[-1].name == "twm"
    assert start[-1].values[0] * intent.turn > 0  # it turns the way asked
    assert renew == [] or renew[-1].name in ("p", "twm")
    assert stop[-1].name == "twm"  # cdp back to 0 and the braking target, one command
    assert all(len(c.text) <= MAX_LINE_CHARS for c in (*start, *renew, *stop))


def test_teleop_keeps_the_five_settings_a_twm_carries():
    teleop = Teleop()
    teleop.board_set("r", "1000")
    teleop.board_set("twm", "-0.3 0.2 -1 0.25 0.15 0")
    assert teleop.board_settings == {"r": "1000", "vg": "-0.3", "cdp": "0.2", "vgr": "-1",
                                     "v": "0.25", "p": "0.15"}  # fmt: skip
    # A twm whose answer went wrong leaves all five unknown, and only those.
    teleop.board_set("twm", None)
    assert teleop.board_settings == {"r": "1000"}


def test_teleop_does_not_send_again_what_a_twm_set():
    teleop = Teleop()
    for command in teleop.safe_settings():
        teleop.board_set(command.name, command.text.split(None, 2)[2])
    first = teleop.step(Intent.FORWARD_RIGHT, still())
    twm = combine_moves(first, teleop.board_settings)[-1]
    teleop.board_set("twm", twm.text.split(None, 2)[2])
    # Renewed once the target is near: nothing but the target goes out, as after the
    # separate sets.
    target = float(twm.text.split()[6])
    renewal = teleop.step(Intent.FORWARD_RIGHT, still(moving=True, cdis=target))
    assert texts(renewal) == [f"set p {twm.text.split()[6]}"]


def test_a_set_the_board_could_not_take_as_written_leaves_its_settings_unknown():
    teleop = Teleop()
    teleop.board_set("vg", "0.3")
    teleop.board_set("twm", "0.1 0.2")
    teleop.board_set("vg", "0.1 0.2")
    assert teleop.board_settings == {}
    with pytest.raises(CommandError):
        Command("set", "twm", 0.1)


# -- on the simulated Giraff-X -------------------------------------------------------------


def drive_curves(firmware: str, combine: bool) -> tuple[TruePose, list[str]]:
    """Teleop's curves (forward, right, left, let go) sent as the control loop sends
    them, each command checked by the guard, on a fresh simulated board; where the robot
    ended and the motion commands that went out."""
    link = BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}")
    clock, teleop, sent = link.port.clock, Teleop(), []

    def watch(exchange: Exchange) -> None:
        if exchange.kind == "set":
            _, name, text = exchange.command.split(None, 2)
            teleop.board_set(name, text if exchange.error is None else None)
            sent.append(exchange.command)

    link.add_observer(watch)
    for command in teleop.safe_settings():
        link.send(command)
    sent.clear()
    keys = [Intent.FORWARD] * 20 + [Intent.FORWARD_RIGHT] * 60 + [Intent.FORWARD_LEFT] * 60
    for intent in [*keys, *[None] * 60]:
        state = link.bulk()
        commands = teleop.step(intent, state)
        if combine:
            commands = combine_moves(commands, teleop.board_settings)
        for command in commands:
            check_command(command, teleop.limits, teleop.board_settings, state.speed or 0.0)
            link.send(command)
        clock.advance(0.05)
    assert not link.bulk().moving
    pose = link.port.board.true_pose
    link.close()
    return pose, sent


def test_on_giraff_x_teleop_s_curves_go_out_as_twms_and_drive_the_same_path():
    separate, sets = drive_curves("thesis", combine=False)
    combined, twms = drive_curves("giraff-x", combine=True)
    # A turn right, a turn left and the stop: one twm each, instead of 4, 3 and 2 commands.
    assert [text.split()[1] for text in twms if not text.startswith("set p ")] == ["twm"] * 3
    assert len(twms) == len(sets) - 6
    assert separate.heading != pytest.approx(0.0, abs=0.1)  # it did turn
    assert math.hypot(combined.x - separate.x, combined.y - separate.y) < 1e-6
    assert combined.heading == pytest.approx(separate.heading, abs=1e-6)


def test_a_twm_separates_into_the_sets_it_stands_for():
    twm = parse_command("set twm -0.3 0.2 -1 0.25 0.15 0")
    assert texts(separate_moves(twm)) == [
        "set vg -0.3", "set cdp 0.2", "set vgr -1", "set v 0.25", "set p 0.15"
    ]  # fmt: skip
    assert after(separate_moves(twm), HELD) == after([twm], HELD)
    for other in batch("set p 0.1", "get twm", "home", "set vg 0.2"):
        assert separate_moves(other) == [other]
    # And back: the separate sets fold into the same twm.
    assert combine_moves(separate_moves(twm), HELD) == [twm]


def test_a_go_s_moves_fold_into_twms_that_pass_the_guard_and_fit_the_line():
    """The executor's batches during a `go` (on the thesis's board, which drives them as
    separate sets), each folded as the loop folds them on Giraff-X and checked in turn
    from the board's picture before the batch."""
    site = Site(Navigator(PLAN, walls_of(PLAN)))
    mission = site.go("lobby")
    folded: list[list[Command]] = []
    step = mission.step

    def watched_step(now: float, state: MotorState | None) -> list[Command]:
        commands = step(now, state)
        combined = combine_moves(commands, site.control.teleop.board_settings)
        board = site.control.teleop.board_settings
        # The speed the loop bounds a move with: the one polled and a tick's acceleration.
        limits = site.control.teleop.limits
        speed = None if state is None else abs(state.speed or 0.0) + limits.accel * TICK
        for command in combined:
            check_command(command, limits, board, speed)
            board.update(command.settings)
        held = site.control.teleop.board_settings
        assert after(combined, held) == after(commands, held)
        folded.append(combined)
        return commands

    mission.step = watched_step  # type: ignore[method-assign]
    site.run(120)
    assert site.ended == ["done"]
    twms = [command for batch in folded for command in batch if command.name == "twm"]
    assert len(twms) > 100
    assert max(len(command.text) for command in twms) <= 49
    # What twm does not carry goes first: the acceleration changes every tick.
    assert all(c.name in ("r", "a", "mode") for batch in folded for c in batch[:-1]
               if batch[-1].name == "twm")  # fmt: skip
