"""No keystroke moves the robot by accident (issue 12): keys typed into the command line
stay there however busy the machine is, keys that move without being held ask first,
quitting asks while anything runs, and letters work with Caps Lock on."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable

from textual import events
from textual.keys import _character_to_key

from tests.tui.conftest import TICK, Rig

SIZE = (100, 30)
# Every printable key the app binds, and what the issue saw leak out of the line.
BOUND = "abcefghjklmpqrtuvxz12345+=-<>.[]?"
BURST = f"patrol resume resumefast {BOUND}"


class Saturated:
    """The machine as the issue found it: the control loop ticking flat out on its own
    thread, flooding the screen with snapshots, and a busy thread holding the GIL."""

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.done = threading.Event()
        self.ticks = 0
        self.threads = [
            threading.Thread(target=self._tick, name="saturated-loop"),
            threading.Thread(target=self._spin, name="saturated-cpu"),
        ]

    def __enter__(self) -> Saturated:
        for thread in self.threads:
            thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        for thread in self.threads:
            thread.join(timeout=10)
            assert not thread.is_alive()

    def _tick(self) -> None:
        # Ten times the loop's rate: as many snapshots as the screen can bear, and more.
        while not self.done.wait(TICK / 10):
            self.rig.control.tick()
            self.rig.clock.advance(TICK)
            self.ticks += 1

    async def until(self, done: Callable[[], bool], seconds: float = 20.0) -> None:
        """Let the app work under the load until `done()`, for at most `seconds`."""
        deadline = time.monotonic() + seconds
        while not done() and time.monotonic() < deadline:
            await asyncio.sleep(0.01)

    def _spin(self) -> None:
        while not self.done.is_set():
            sum(range(10_000))


def burst(rig: Rig, text: str) -> None:
    """`text` typed faster than the screen takes it: every key queued before the app
    has handled the first, as a busy machine hands them over."""
    for character in text:
        key = "enter" if character == "\r" else _character_to_key(character)
        rig.app._driver.send_message(events.Key(key, character))


def typed_commands(rig: Rig) -> list[str]:
    """Every line the command line sends, from now on."""
    commands: list[str] = []
    run_command = rig.app.run_command
    rig.app.run_command = lambda text: (commands.append(text), run_command(text))  # type: ignore[method-assign]
    return commands


def operator_sent(rig: Rig) -> list[str]:
    """Every command that goes to the board, but for the automatic polls."""
    sent: list[str] = []
    rig.link.add_observer(lambda e: None if e.automatic else sent.append(e.command))
    return sent


async def test_keys_typed_after_enter_on_a_saturated_machine_all_go_into_the_line(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.2)
        sent = operator_sent(rig)
        commands = typed_commands(rig)
        notes = len(rig.app.status_log.texts)
        start = rig.board.true_pose
        with Saturated(rig) as load:
            await load.until(lambda: load.ticks >= 10)  # the loop is busy before the keys
            burst(rig, "\r" + BURST)
            await load.until(lambda: rig.app.command_line.value == BURST)
        await pilot.pause()
        assert load.ticks >= 10
        assert rig.app.command_line.is_open and rig.app.command_line.has_focus
        assert rig.app.command_line.value == BURST
        # No binding ran: no poll toggle, no recording, no question, nothing sent.
        assert rig.control.autopoll
        assert rig.sessions is not None and not rig.sessions.recording
        assert rig.control.mission is None
        assert rig.app.is_running and rig.app.screen is rig.app.screen_stack[0]
        assert rig.app.status_log.texts[notes:] == []
        assert sent == [] and commands == []
        assert rig.board.true_pose == start


async def test_enter_sends_each_line_once_and_clears_it_at_once(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        commands = typed_commands(rig)
        with Saturated(rig) as load:
            await load.until(lambda: load.ticks >= 10)
            burst(rig, "\rresume\r\rfast\r\rget v\r")
            await load.until(lambda: len(commands) == 3)
        await pilot.pause()
        assert commands == ["resume", "fast", "get v"]
        assert not rig.app.command_line.is_open and rig.app.command_line.value == ""


async def test_keys_after_the_line_is_sent_reach_their_bindings_again(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        burst(rig, "\rget v\ra")
        await pilot.pause()
        assert not rig.control.autopoll


async def test_undock_home_and_tilt_keys_send_nothing_without_their_confirmation(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        sent = operator_sent(rig)
        # The same key again is no confirmation either: it may be a held key's repeat.
        for key, other in (("u", "x"), ("h", "h"), ("t", "a"), ("u", "u"), ("u", "enter")):
            await pilot.press(key)
            assert sent == [] and rig.control.mission is None
            await pilot.press(other)  # any other key says no, and does nothing else
            await rig.run(pilot, 0.5)
        assert rig.control.autopoll and not rig.app.command_line.is_open
        assert sent == [] and rig.board.true_pose.x == 0
        notes = " ".join(rig.app.status_log.texts)
        assert "undock: back out 0.3 m and turn round?" in notes
        assert "home the head?" in notes and "tilt the head up?" in notes


async def test_a_confirmation_too_late_does_nothing(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("u")
        await rig.run(pilot, 6.0)
        await pilot.press("y")
        await rig.run(pilot, 1.0)
        assert rig.board.true_pose.x == 0 and rig.control.mission is None
        assert "answered too late" in " ".join(rig.app.status_log.texts)


async def test_undock_confirmed_backs_out_in_streamed_steps_never_with_set_undock(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        sent = operator_sent(rig)
        await pilot.press("u", "y")
        await rig.run(pilot, 1.0)
        assert rig.board.true_pose.x < -0.05
        assert not any(command.startswith("set undock") for command in sent)


async def test_home_and_tilt_confirmed_with_y(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        sent = operator_sent(rig)
        await pilot.press("h", "y", "t", "y")
        await rig.run(pilot, 0.1)
        assert "home" in sent and "set tilt_angle_from_home 1" in sent


async def test_escape_twice_from_the_command_line_does_not_quit(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        burst(rig, "\rpatrol")
        await pilot.press("escape", "escape")
        assert rig.app.is_running and rig.app.return_code is None
        assert not rig.app.command_line.is_open
        assert "quit?" in rig.app.status_log.texts[-1]
        await pilot.press("n")
        assert rig.app.is_running and rig.app.return_code is None


async def test_quit_while_recording_asks_first(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("r")
        await rig.run(pilot, 0.1)
        assert rig.sessions is not None and rig.sessions.recording
        # One way to quit, one question: Ctrl-C asks what Esc and q ask (Textual's own
        # question, a third way out, is not shown).
        for quit_key in ("q", "escape", "ctrl+c"):
            await pilot.press(quit_key)
            assert "quit? recording" in rig.app.status_log.texts[-1]
            await pilot.press("q")  # not y: stays
            assert rig.app.return_code is None and rig.sessions.recording
        await pilot.press("escape", "y")
        await pilot.pause()
        assert rig.app.return_code == 0


async def test_typed_quit_with_nothing_running_quits_at_once(rig):
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        burst(rig, "\rquit\r")
        await pilot.pause()
        assert rig.app.return_code == 0


async def test_letter_keys_work_with_caps_lock_on(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        sent = operator_sent(rig)
        await pilot.press("A", "R")
        await rig.run(pilot, 0.1)
        assert not rig.control.autopoll
        assert rig.sessions is not None and rig.sessions.recording
        await pilot.press("H", "Y", "B")
        await rig.run(pilot, 0.1)
        assert "home" in sent and "get bulk_data" in sent
        # Typed text keeps its case: Caps Lock is not the keys' business there.
        await pilot.press("enter", "G", "O")
        assert rig.app.command_line.value == "GO"


async def test_space_stops_a_mission_while_a_question_waits(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("u", "y")
        await rig.run(pilot, 0.5)  # backing out
        assert rig.control.mission is not None
        await pilot.press("h", "space")  # a stray h asks; Space is still the stop key
        await rig.run(pilot, 0.1)
        assert rig.control.mission is None
        assert "home" not in operator_sent(rig)


async def test_space_stops_the_robot_with_the_help_screen_open(tmp_path):
    rig = Rig(recordings=tmp_path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        await pilot.press("u", "y")
        await rig.run(pilot, 0.5)
        await pilot.press("question_mark")
        await rig.run(pilot, 0.1)
        assert len(rig.app.screen_stack) > 1
        await pilot.press("space")
        await rig.run(pilot, 0.1)
        assert rig.control.mission is None
