"""Playback timing: recorded times kept at any speed, pause, step, seek, the end."""

from __future__ import annotations

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.recording.control_log import LogEntry, LogRead
from giraff_console.recording.playback import Playback

OFFSETS = [0.0, 0.5, 1.0, 1.5, 2.0, 4.0]


@pytest.fixture
def clock() -> VirtualClock:
    return VirtualClock()


def playback(clock: VirtualClock, speed: float = 1.0) -> Playback:
    entries = [LogEntry(t, "G", "v", f"{i}", line_no=i + 1) for i, t in enumerate(OFFSETS)]
    return Playback("test", LogRead(entries, []), clock.now(), speed)


def offsets(entries) -> list[float]:
    return [entry.offset for entry in entries]


def test_entries_fall_due_at_their_recorded_times(clock):
    play = playback(clock)
    assert offsets(play.due(clock.now())) == [0.0]
    assert play.next_due() == pytest.approx(clock.now() + 0.5)
    clock.advance(0.49)
    assert play.due(clock.now()) == []
    clock.advance(0.01)
    assert offsets(play.due(clock.now())) == [0.5]
    clock.advance(3.5)
    assert offsets(play.due(clock.now())) == [1.0, 1.5, 2.0, 4.0]
    assert play.next_due() is None


@pytest.mark.parametrize("speed", [0.25, 2.0, 16.0])
def test_at_any_speed_the_log_takes_its_duration_divided_by_the_speed(clock, speed):
    play = playback(clock, speed)
    start = clock.now()
    handed_out = []
    while not play.finished(clock.now()):
        handed_out += play.due(clock.now())
        clock.advance(max(1e-3, (play.next_due() or clock.now() + 0.01) - clock.now()))
    assert offsets(handed_out) == OFFSETS
    assert clock.now() - start == pytest.approx(4.0 / speed, abs=0.011)


def test_speed_is_held_between_a_quarter_and_sixteen(clock):
    play = playback(clock)
    assert play.set_speed(clock.now(), 100) == 16.0
    assert play.set_speed(clock.now(), 0.01) == 0.25


def test_pause_holds_the_position_and_resume_carries_on_from_it(clock):
    play = playback(clock)
    play.due(clock.now())
    clock.advance(0.7)
    play.pause(clock.now())
    clock.advance(10)
    assert play.position(clock.now()) == pytest.approx(0.7)
    assert offsets(play.due(clock.now())) == [0.5]
    assert play.next_due() is None
    play.resume(clock.now())
    clock.advance(0.3)
    assert offsets(play.due(clock.now())) == [1.0]


def test_each_step_moves_to_the_next_line_even_before_the_loop_takes_it(clock):
    play = playback(clock)
    play.due(clock.now())
    clock.advance(0.2)
    assert play.step(clock.now()) == 0.5
    assert play.step(clock.now()) == 1.0  # twice within one tick: two lines on
    assert play.paused
    assert offsets(play.due(clock.now())) == [0.5, 1.0]


def test_a_paused_playback_at_its_end_waits_for_the_operator(clock):
    play = playback(clock)
    for _ in OFFSETS:
        play.step(clock.now())
    play.due(clock.now())
    assert play.position(clock.now()) == 4.0
    assert not play.finished(clock.now())
    play.resume(clock.now())
    assert play.finished(clock.now())


def test_seek_returns_everything_up_to_there_and_goes_on_from_it(clock):
    play = playback(clock)
    clock.advance(3.0)
    play.due(clock.now())
    assert play.seek(clock.now(), 1.2) == 3  # 0.0, 0.5 and 1.0 lie before
    clock.advance(0.3)
    assert offsets(play.due(clock.now())) == [1.5]
    assert play.seek(clock.now(), 99) == len(OFFSETS)  # held to the end
