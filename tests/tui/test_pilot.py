"""The console driven with keys, as an operator would, on the simulator."""

from __future__ import annotations

import math

import pytest

from giraff_console.link import LinkDisconnected
from tests.tui.conftest import Rig

SIZE = (100, 30)


async def test_holding_up_moves_the_robot_and_the_pose_on_screen(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await rig.hold(pilot, "up", 2.0)
        rig.control.tick()  # a poll now, at the time the true pose is read
        await pilot.pause()
        assert rig.board.true_pose.x > 0.5
        shown = f"X={rig.control.odometry.pose.x:.2f}"
        assert shown in str(rig.app.top_bar.render())
        assert rig.control.odometry.pose.x == pytest.approx(rig.board.true_pose.x, abs=1e-3)


@pytest.mark.parametrize("firmware", ["later", "giraff-x"])
async def test_holding_the_keys_drives_and_the_pose_follows_on_later_firmware(firmware):
    rig = Rig(firmware=firmware)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await rig.hold(pilot, "up", 2.0)
        await rig.hold(pilot, "pageup", 2.0)
        await rig.hold(pilot, "left", 1.0)
        await rig.run(pilot, 1.5)
        rig.control.tick()  # a poll now, at the time the true pose is read
        true, pose = rig.board.true_pose, rig.control.odometry.pose
        assert math.hypot(true.x, true.y) > 0.8
        assert math.hypot(pose.x - true.x, pose.y - true.y) < 1e-3
        assert abs(math.remainder(pose.heading - true.heading, math.tau)) < math.radians(0.1)


async def test_the_robot_stops_when_the_repeats_stop(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        sent = []
        rig.link.add_observer(lambda e: sent.append((e.sent_at, e.command)))
        await rig.hold(pilot, "up", 2.0)
        last_repeat = rig.clock.now()
        x = rig.board.true_pose.x
        await rig.run(pilot, 1.5)
        # The stop is a target of the braking distance plus 10 ms: 0.164 m at 0.4 m/s.
        stop = [
            t for t, command in sent
            if t >= last_repeat and command.startswith("set p ") and float(command[6:]) < 0.2
        ]  # fmt: skip
        assert stop and stop[0] - last_repeat <= 0.7
        assert not rig.link.bulk().moving
        assert rig.board.true_pose.x - x < 0.3


async def test_enter_and_a_raw_command_put_the_reply_in_the_transcript(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("enter")
        assert rig.app.command_line.has_focus
        await pilot.press(*"get v", "enter")
        await rig.run(pilot, 0.1)
        lines = rig.app.transcript.texts
        assert "> get v" in lines
        assert "  0.40000" in lines  # the console set the driving speed on connecting
        assert not rig.app.command_line.display


async def test_diagonal_keys_drive_a_curve(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.hold(pilot, "pageup", 3.0)
        state = rig.link.bulk()
        assert 0 < state.cvg < 0.51
        assert rig.board.true_pose.heading < -math.radians(5)  # curving right


async def test_commands_outside_the_limits_are_refused(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)  # connected, settings within the limits sent
        sent = []
        rig.link.add_observer(lambda e: sent.append(e.command))
        refused = ("set v 2", "set p 5", "set vg 0.6", "get v\rset p 5", "set mode 1",
                   "set mode 4", "set a 3", "set a 0.01", "set undock 2")  # fmt: skip
        for text in refused:
            rig.app.run_command(text)
        await rig.run(pilot, 0.1)
        notes = [note for note in rig.app.status_log.texts if "refused" in note]
        # Repeated identical refusals come as one line ending in a multiplication sign
        # and the count.
        times = [note.rpartition("\N{MULTIPLICATION SIGN}")[2] for note in notes]
        assert sum(int(n) if n.isdigit() else 1 for n in times) == len(refused)
        assert not any(
            c.startswith(("set v", "set p", "set vg", "set a", "set undock")) for c in sent
        )
        assert not any(c.startswith("set mode") and c != "set mode 0" for c in sent)


async def test_poll_toggle_and_help_screen(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("a")
        await rig.run(pilot, 0.1)
        assert "POLL OFF" in str(rig.app.top_bar.render())
        await pilot.press("question_mark")
        assert rig.app.screen.__class__.__name__ == "HelpScreen"
        await pilot.press("escape")
        assert rig.app.screen.__class__.__name__ != "HelpScreen"


async def test_go_to_a_room_the_floor_plan_has_not_says_which_it_has(rig):
    """On the rig's open floor (one room, no map shown)."""
    async with rig.app.run_test(size=SIZE) as pilot:
        rig.app.run_command("go kitchen")
        await pilot.pause()
        assert "go: no room called 'kitchen' (rooms: floor)" in " ".join(rig.app.status_log.texts)
        assert not rig.app.map_view.display
        assert not rig.control.running


async def test_escape_while_moving_asks_then_quits_and_leaves_the_robot_stopped(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.hold(pilot, "up", 2.5)
        x = rig.board.true_pose.x
        await pilot.press("escape")
        assert rig.app.is_running
        assert "quit? the robot is moving" in " ".join(rig.app.status_log.texts)
        await pilot.press("y")
        await pilot.pause()
        assert rig.app.return_code == 0  # it has exited
    rig.clock.advance(5)
    assert rig.board.true_pose.x - x <= 0.17  # the braking distance plus margin
    assert rig.link.port.board.drive.velocity == 0


@pytest.mark.parametrize("keys", [["h", "y"], ["t", "y"], ["b"]])
async def test_board_keys_send_their_commands(rig, keys):
    expected = {"h": "home", "t": "set tilt_angle_from_home 1", "b": "get bulk_data"}[keys[0]]
    async with rig.app.run_test(size=SIZE) as pilot:
        sent = []
        rig.link.add_observer(lambda e: sent.append((e.command, e.automatic)))
        await pilot.press(*keys)
        await rig.run(pilot, 0.1)
        assert (expected, False) in sent


async def test_the_command_line_remembers_and_completes(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await pilot.press("enter", *"get v", "enter")
        await pilot.press("enter", "up")
        assert rig.app.command_line.value == "get v"
        await pilot.press("escape")
        await pilot.press("enter", *"get bulk_d")
        await pilot.press("tab")  # takes the suggestion
        assert rig.app.command_line.value == "get bulk_data"


async def test_the_board_defaults_are_replaced_by_safe_settings_on_connecting(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        settings = rig.control.teleop.board_settings
        assert (settings["v"], settings["a"], settings["vg"], settings["mode"]) == (
            "0.4",
            "0.5",
            "0",
            "0",
        )
        # A steep gear rate cannot reach past vg, which stays within the limit.
        for text in ("set vgr 2", "set cdp 0.25", "set p 0.25"):
            rig.app.run_command(text)
        await rig.run(pilot, 2.0)
        assert rig.board.true_pose.x == pytest.approx(0.25, abs=0.01)
        assert rig.board.true_pose.heading == 0.0


async def test_commands_typed_while_the_link_is_lost_are_not_sent_later(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        link = rig.link
        rig.control.connect = lambda: (_ for _ in ()).throw(LinkDisconnected("unplugged"))
        link.port.close()
        await rig.run(pilot, 0.1)
        rig.app.run_command("set p 0.2")
        await rig.run(pilot, 0.1)
        assert any("not sent" in note for note in rig.app.status_log.texts)


async def test_space_stops_an_undock_half_way(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("u", "y")
        await rig.run(pilot, 0.5)  # backing out
        assert rig.board.true_pose.x < -0.05
        await pilot.press("space")
        await rig.run(pilot, 5.0)
        assert not rig.link.bulk().moving
        assert rig.board.true_pose.x > -0.3  # did not finish backing out...
        assert rig.board.true_pose.heading == 0.0  # ...nor turn around


async def test_estop_is_reported_once_and_teleop_sends_no_target_after_it(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        sent = []
        rig.link.add_observer(lambda e: sent.append(e.command))
        await rig.hold(pilot, "up", 1.0)
        rig.board.set_estop(True)
        await rig.run(pilot, 0.1)
        sent.clear()
        await rig.hold(pilot, "up", 1.0)
        assert not [c for c in sent if c.startswith("set p")]
        assert sum("ESTOP raised" in note for note in rig.app.status_log.texts) == 1
        assert "ESTOP" in str(rig.app.top_bar.render())


async def test_the_help_screen_scrolls_with_the_arrows(rig):
    async with rig.app.run_test(size=(80, 24)) as pilot:
        await pilot.press("question_mark")
        scroller = rig.app.screen.query_one("VerticalScroll")
        await pilot.press("down", "down", "down")
        assert scroller.scroll_y > 0
        assert rig.board.true_pose.x == 0  # the arrows did not drive


async def test_the_camera_view_moves_with_the_robot_and_keys_change_its_resolution(camera_rig):
    rig = camera_rig
    async with rig.app.run_test(size=(120, 40)) as pilot:
        await rig.run(pilot, 0.1)
        await rig.show_camera(pilot)
        before = rig.app.camera_view.picture
        assert "cam 800x600" in rig.app.top_bar.camera and "FAST" in rig.app.top_bar.camera
        await rig.hold(pilot, "up", 1.5)
        await rig.show_camera(pilot)
        assert rig.app.camera_view.picture.lines != before.lines
        await pilot.press("5")
        await rig.show_camera(pilot)
        assert "cam 640x480" in rig.app.top_bar.camera
        await pilot.press("f")
        await rig.show_camera(pilot)
        assert "FAST" not in rig.app.top_bar.camera


async def test_the_palette_offers_the_rooms_and_the_robot_s_commands_from_one_table(care_home_rig):
    rig = care_home_rig
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.2)
        await pilot.press("ctrl+p")
        await pilot.pause()
        for key in "status":
            await pilot.press(key)
        await pilot.pause(0.5)
        await pilot.press("enter")
        await pilot.pause()
        await rig.run(pilot, 0.1)
        lines = "\n".join(str(line) for line in rig.app.status_log.lines)
        assert "mission: none" in lines and "controls:" in lines
