"""The two-stage deadman: grace after the first press, then a short repeat timeout."""

from __future__ import annotations

import pytest

from giraff_console.clock import VirtualClock
from giraff_console.robot.deadman import Deadman, Intent


@pytest.fixture
def held():
    clock = VirtualClock()
    return clock, Deadman(clock, grace=0.55, repeat_timeout=0.15)


def test_a_first_press_is_held_through_the_terminals_initial_delay(held):
    clock, deadman = held
    deadman.press(Intent.FORWARD)
    clock.advance(0.5)
    assert deadman.held() is Intent.FORWARD
    clock.advance(0.1)
    assert deadman.held() is None


def test_repeats_keep_it_held_and_a_gap_lets_go(held):
    clock, deadman = held
    deadman.press(Intent.FORWARD)
    clock.advance(0.5)
    for _ in range(30):
        deadman.press(Intent.FORWARD)
        clock.advance(0.033)
        assert deadman.held() is Intent.FORWARD
    clock.advance(0.15)
    assert deadman.held() is None


def test_after_repeats_the_short_timeout_applies(held):
    clock, deadman = held
    deadman.press(Intent.LEFT)
    clock.advance(0.5)
    deadman.press(Intent.LEFT)
    clock.advance(0.2)  # shorter than the grace, longer than the repeat timeout
    assert deadman.held() is None


def test_another_key_starts_over(held):
    clock, deadman = held
    deadman.press(Intent.FORWARD)
    clock.advance(0.5)
    deadman.press(Intent.FORWARD)
    deadman.press(Intent.FORWARD_RIGHT)  # a new first press: grace again
    clock.advance(0.4)
    assert deadman.held() is Intent.FORWARD_RIGHT


def test_release_lets_go_at_once(held):
    _, deadman = held
    deadman.press(Intent.BACKWARD)
    deadman.release()
    assert deadman.held() is None


def test_times_must_be_positive():
    with pytest.raises(ValueError):
        Deadman(VirtualClock(), grace=0)
