"""The status log: a message repeated again and again shows once, with its count."""

from __future__ import annotations

from textual.app import App, ComposeResult

from giraff_console.tui.status_log import Repeats, StatusLog, message_of


def test_the_clock_time_is_not_part_of_the_message():
    assert message_of("12:00:01 board error: Queue rollover") == "board error: Queue rollover"
    assert message_of("no time here") == "no time here"


def test_twenty_identical_messages_collapse_into_one_line_with_a_count():
    repeats = Repeats()
    shown = [repeats.add(f"12:00:{i:02d} board error: Queue rollover") for i in range(20)]
    assert shown[0] == ("12:00:00 board error: Queue rollover", False)
    assert shown[-1] == ("12:00:19 board error: Queue rollover … \N{MULTIPLICATION SIGN}20", True)
    assert all(replaces for _, replaces in shown[1:])


def test_a_different_message_starts_a_new_line_and_a_new_count():
    repeats = Repeats()
    repeats.add("12:00:00 stop")
    repeats.add("12:00:01 stop")
    assert repeats.add("12:00:02 driving speed 0.30 m/s") == (
        "12:00:02 driving speed 0.30 m/s",
        False,
    )
    assert repeats.add("12:00:03 stop") == ("12:00:03 stop", False)


class _LogApp(App):
    def compose(self) -> ComposeResult:
        yield StatusLog()


async def test_the_widget_shows_a_flood_as_one_line_and_keeps_the_lines_around_it():
    app = _LogApp()
    async with app.run_test(size=(60, 20)) as pilot:
        await pilot.pause()
        log = app.query_one(StatusLog)
        log.note("12:00:00 recording started")
        for i in range(20):
            log.note(f"12:00:{i:02d} board error: ERROR: Queue rollover")
        log.note("12:00:21 stop")
        await pilot.pause()
        assert log.texts == [
            "12:00:00 recording started",
            "12:00:19 board error: ERROR: Queue rollover … \N{MULTIPLICATION SIGN}20",
            "12:00:21 stop",
        ]
        assert len(log.lines) == 3  # rows on screen: the 19 repeats were taken back out
