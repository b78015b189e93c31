"""The battery and the height stalk on the top line, and the stalk's commands and keys,
on the simulator's later board (and the thesis's, where neither exists)."""

from __future__ import annotations

import re

import pytest

from giraff_console.protocol.charger import ChargeStatus
from giraff_console.robot.battery import Battery
from giraff_console.tui.top_bar import battery_text, stalk_text
from tests.tui.conftest import Rig

SIZE = (120, 30)
# Long enough for the loop to have read every charger parameter (one each 0.5 s) and h.
SETTLE_S = 4.0


def top_line(rig: Rig) -> str:
    return str(rig.app.top_bar.render())


def sent_commands(rig: Rig) -> list[str]:
    """Every command the link sends from now on, except the loop's own reads."""
    sent: list[str] = []
    rig.link.add_observer(lambda e: None if e.automatic else sent.append(e.command))
    return sent


# -- the top line's text ---------------------------------------------------------------


def test_a_charging_battery_shows_its_percent_a_bolt_and_its_voltage():
    battery = Battery(ChargeStatus.FAST_CHARGING, 73.4, 25.06, 2.0, 30.0)
    assert battery_text(battery, low=25) == ("BAT 73% ⚡ 25.1 V", "bold")


def test_a_low_battery_is_red_and_says_low():
    text, style = battery_text(Battery(ChargeStatus.NOT_DOCKED, 18.2, 22.6), low=25)
    assert text == "BAT 18% LOW 22.6 V"
    assert "red" in style


def test_a_low_battery_on_its_charger_is_not_an_alarm():
    text, style = battery_text(Battery(ChargeStatus.TRICKLE_CHARGING, 18.0, 24.0), low=25)
    assert text == "BAT 18% ⚡ 24.0 V"
    assert "red" not in style


def test_a_charger_error_is_red():
    text, style = battery_text(Battery(ChargeStatus.ERROR, 60.0, 24.0), low=25)
    assert text == "BAT 60% CHARGER ERROR 24.0 V"
    assert "red" in style


def test_what_the_charger_has_not_reported_yet_is_left_out():
    assert battery_text(Battery(ChargeStatus.NOT_DOCKED), low=25)[0] == "BAT --%"
    assert battery_text(Battery(ChargeStatus.INIT, 50.0), low=25)[0] == "BAT 50% charger starting"


def test_the_stalk_shows_its_setting_and_the_head_height():
    assert stalk_text(0) == "stalk 0 1.16 m"
    assert stalk_text(520) == "stalk 520 1.29 m"
    assert stalk_text(1000) == "stalk 1000 1.41 m"


# -- on the simulator ------------------------------------------------------------------


async def test_the_thesis_board_shows_no_battery_and_no_stalk(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, SETTLE_S)
        line = top_line(rig)
        assert "X=0.00" in line
        assert "BAT" not in line and "stalk" not in line


async def test_a_later_board_shows_its_battery_and_stalk():
    rig = Rig(firmware="later", battery=0.6)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, SETTLE_S)
        line = top_line(rig)
        shown = re.search(r"BAT (\d+)% (?:⚡ )?(\d+\.\d) V", line)
        assert shown, line
        assert int(shown.group(1)) == pytest.approx(100 * rig.board.battery_level, abs=1.5)
        assert "stalk 0 1.16 m" in line


async def test_at_80_columns_the_pose_and_battery_stay_and_the_camera_part_goes():
    rig = Rig(firmware="later", battery=0.6)
    async with rig.app.run_test(size=(80, 24)) as pilot:
        await rig.run(pilot, SETTLE_S)
        line = top_line(rig)
        assert re.search(r"X=\S+ Y=\S+ H=\S+", line) and "BAT" in line, line
        assert "cam" not in line and "…" not in line, line


async def test_stalk_n_sets_h_and_the_top_line_follows():
    rig = Rig(firmware="later")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        sent = sent_commands(rig)
        rig.app.run_command("stalk 600")
        await rig.run(pilot, 15.0)  # the stalk moves at a finite speed
        assert sent == ["set h 600"]
        assert "stalk 600 1.31 m" in top_line(rig)
        assert "stalk to 600 (head at 1.31 m)" in " ".join(rig.app.status_log.texts)


async def test_stalk_up_and_down_step_from_the_reported_height():
    rig = Rig(firmware="later")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        rig.app.run_command("stalk 500")
        await rig.run(pilot, 15.0)
        sent = sent_commands(rig)
        rig.app.run_command("stalk up")
        await rig.run(pilot, 0.6)  # on its way up, and read again on the way
        reported = rig.app.telemetry.stalk
        assert reported is not None and 500 < reported < 600
        rig.app.run_command("stalk down")
        await rig.run(pilot, 0.1)
        # Down from where it is, not from where it was sent: a held key stays one step
        # from the stalk.
        assert sent == ["set h 600", f"set h {reported - 100}"]


async def test_the_keys_g_and_v_raise_and_lower_it_without_asking():
    rig = Rig(firmware="later")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        sent = sent_commands(rig)
        await pilot.press("g")
        await rig.run(pilot, 15.0)
        assert "stalk 100 1.18 m" in top_line(rig)
        await pilot.press("v")
        await rig.run(pilot, 0.2)
        assert sent == ["set h 100", "set h 0"]


async def test_the_stalk_stays_within_its_range():
    rig = Rig(firmware="later")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        sent = sent_commands(rig)
        rig.app.run_command("stalk down")  # at 0 already
        await rig.run(pilot, 0.1)
        assert "already at its bottom" in rig.app.status_log.texts[-1]
        for typed in ("stalk 1001", "stalk -1", "stalk 2.5", "stalk high", "stalk"):
            rig.app.run_command(typed)
            await rig.run(pilot, 0.1)
            # The log folds repeats of a line into one: the last line is the refusal.
            assert "refused: usage: stalk up" in rig.app.status_log.texts[-1]
        assert sent == []


async def test_a_typed_set_h_out_of_range_is_refused_by_the_guard():
    rig = Rig(firmware="later")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        sent = sent_commands(rig)
        rig.app.run_command("set h 1200")
        await rig.run(pilot, 0.2)
        assert sent == []
        assert "refused" in rig.app.status_log.texts[-1]


async def test_the_thesis_board_has_no_stalk_to_move(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 1.0)
        sent = sent_commands(rig)
        await pilot.press("g")
        rig.app.run_command("stalk 500")
        await rig.run(pilot, 0.2)
        assert sent == []
        assert "no height stalk" in rig.app.status_log.texts[-1]


async def test_the_help_screen_lists_the_stalk_keys_and_command(rig):
    async with rig.app.run_test(size=(100, 60)) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("question_mark")
        help_screen = rig.app.screen
        keys = {binding.key: binding.tooltip for binding in help_screen.key_bindings}
        assert "raise the head" in keys["g"] and "lower the head" in keys["v"]
        assert "stalk up|down|N" in dict(help_screen.commands)
