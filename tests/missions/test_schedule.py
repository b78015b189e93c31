"""Scheduled patrols: when each is due, and whether the daemon starts it."""

from __future__ import annotations

import datetime as dt

import pytest

from giraff_console.missions.schedule import (
    ScheduledPatrol,
    ScheduleEntryError,
    Scheduler,
    next_due,
    parse_every,
    scheduled_patrol,
)

NIGHT = ScheduledPatrol("night", 2 * 3600, dt.time(22, 0), dt.time(6, 0))


def at(day: int, hour: int, minute: int = 0, second: int = 0) -> dt.datetime:
    """A local time in January 2025."""
    return dt.datetime(2025, 1, day, hour, minute, second)


def idle(name: str) -> bool:
    return False


def busy(name: str) -> bool:
    return True


def due_times(entry: ScheduledPatrol, after: dt.datetime, until: dt.datetime) -> list:
    times = []
    when = next_due(entry, after)
    while when <= until:
        times.append(when)
        when = next_due(entry, when)
    return times


def test_a_night_window_runs_every_two_hours_across_midnight_end_included():
    assert due_times(NIGHT, at(1, 12), at(2, 12)) == [
        at(1, 22), at(2, 0), at(2, 2), at(2, 4), at(2, 6),
    ]  # fmt: skip


def test_an_end_off_the_grid_is_not_run():
    entry = ScheduledPatrol("night", 2 * 3600, dt.time(22, 0), dt.time(5, 0))
    assert due_times(entry, at(1, 12), at(2, 12))[-1] == at(2, 4)


def test_the_next_night_starts_again_at_the_window_start():
    assert next_due(NIGHT, at(2, 6)) == at(2, 22)


def test_a_window_inside_one_day():
    entry = ScheduledPatrol("day", 90 * 60, dt.time(8, 0), dt.time(12, 0))
    assert due_times(entry, at(1, 0), at(1, 23)) == [
        at(1, 8), at(1, 9, 30), at(1, 11),
    ]  # fmt: skip


def test_start_equal_to_end_is_all_day_and_midnight_runs_once():
    entry = ScheduledPatrol("round", 8 * 3600, dt.time(0, 0), dt.time(0, 0))
    assert entry.all_day
    assert due_times(entry, at(1, 0), at(2, 23)) == [
        at(1, 8), at(1, 16), at(2, 0), at(2, 8), at(2, 16),
    ]  # fmt: skip


def test_an_all_day_grid_restarts_at_its_start_each_day():
    entry = ScheduledPatrol("round", 7 * 3600, dt.time(9, 0), dt.time(9, 0))
    assert due_times(entry, at(1, 8), at(2, 10)) == [
        at(1, 9), at(1, 16), at(1, 23), at(2, 6), at(2, 9),
    ]  # fmt: skip


def test_a_daemon_started_at_2310_runs_the_night_patrol_first_at_midnight():
    scheduler = Scheduler([NIGHT], now=at(1, 23, 10))
    assert scheduler.tick(at(1, 23, 59, 59), idle) == []
    [decision] = scheduler.tick(at(2, 0, 0, 1), idle)
    assert (decision.start, decision.at, decision.missed) == (True, at(2, 0), 0)
    assert decision.why == "due at 00:00"


def test_each_slot_is_decided_once():
    scheduler = Scheduler([NIGHT], now=at(1, 21))
    assert len(scheduler.tick(at(1, 22), idle)) == 1
    assert scheduler.tick(at(1, 22, 0, 5), idle) == []
    assert scheduler.upcoming() == [(NIGHT, at(2, 0))]


def test_a_whole_night_ticked_every_minute_runs_five_times():
    scheduler = Scheduler([NIGHT], now=at(1, 12))
    started = []
    now = at(1, 12)
    while now < at(2, 12):
        now += dt.timedelta(minutes=1)
        started += [d.at for d in scheduler.tick(now, idle) if d.start]
    assert started == [at(1, 22), at(2, 0), at(2, 2), at(2, 4), at(2, 6)]


def test_a_slot_whose_patrol_is_still_running_is_skipped_and_says_why():
    scheduler = Scheduler([NIGHT], now=at(1, 21))
    [decision] = scheduler.tick(at(1, 22), busy)
    assert not decision.start
    assert decision.why == "the previous run of night has not finished"
    # Skipped, not queued: the next is the next slot.
    assert scheduler.tick(at(1, 23), idle) == []
    assert scheduler.upcoming()[0][1] == at(2, 0)


def test_running_is_asked_about_the_entrys_own_patrol():
    other = ScheduledPatrol("garden", 3600, dt.time(22, 0), dt.time(23, 0))
    scheduler = Scheduler([NIGHT, other], now=at(1, 21))
    decisions = scheduler.tick(at(1, 22), lambda name: name == "night")
    assert {(d.entry.patrol, d.start) for d in decisions} == {("night", False), ("garden", True)}


def test_two_entries_for_one_patrol_due_at_once_start_it_once():
    hourly = ScheduledPatrol("night", 3600, dt.time(22, 0), dt.time(6, 0))
    scheduler = Scheduler([NIGHT, hourly], now=at(1, 21))
    first, second = scheduler.tick(at(1, 22), idle)
    assert first.start and not second.start
    assert second.why == "night is starting now for another schedule entry"


def test_a_clock_jump_runs_once_and_counts_the_missed_slots():
    scheduler = Scheduler([NIGHT], now=at(1, 23, 30))
    # Suspended at 23:30, resumed at 05:10: 00:00, 02:00 and 04:00 have passed.
    [decision] = scheduler.tick(at(2, 5, 10), idle)
    assert (decision.start, decision.at, decision.missed) == (True, at(2, 4), 2)
    assert decision.why.startswith("due at 04:00; 2 earlier runs missed")
    assert scheduler.tick(at(2, 5, 11), idle) == []
    assert scheduler.upcoming()[0][1] == at(2, 6)


@pytest.mark.parametrize(
    "entry", [NIGHT, ScheduledPatrol("round", 7 * 3600, dt.time(9, 0), dt.time(9, 0))]
)
def test_a_jump_of_weeks_counts_every_missed_slot(entry):
    created, woken = at(1, 23, 30), at(20, 3, 10)
    [decision] = Scheduler([entry], now=created).tick(woken, idle)
    slots = due_times(entry, created, woken)
    assert (decision.at, decision.missed) == (slots[-1], len(slots) - 1)


def test_a_slot_found_after_its_window_has_ended_is_not_started():
    scheduler = Scheduler([NIGHT], now=at(1, 21))
    # Asleep all night, woken at 09:00: no night patrol among the residents' breakfast.
    [decision] = scheduler.tick(at(2, 9), idle)
    assert not decision.start
    assert decision.at == at(2, 6)
    assert "had passed when the console woke (5 runs missed)" in decision.why
    assert scheduler.upcoming()[0][1] == at(2, 22)


def test_the_last_slot_found_a_moment_late_still_runs():
    scheduler = Scheduler([NIGHT], now=at(2, 5))
    [decision] = scheduler.tick(at(2, 6, 0, 30), idle)
    assert decision.start and decision.at == at(2, 6)


@pytest.mark.parametrize(
    ("text", "seconds"),
    [("2h", 7200), ("90m", 5400), ("1h30m", 5400), ("45s", 45), ("1h0m30s", 3630)],
)
def test_durations(text, seconds):
    assert parse_every(text) == seconds


@pytest.mark.parametrize("text", ["", "2", "h", "2 h", "1.5h", "-2h", "2d", "30m1h", 7200])
def test_what_is_not_a_duration(text):
    with pytest.raises(ValueError, match="every should be a duration"):
        parse_every(text)


def test_a_table_becomes_a_scheduled_patrol():
    table = {"patrol": "night", "every": "2h", "from": "22:00", "to": "06:00"}
    assert scheduled_patrol(table) == NIGHT
    everywhen = scheduled_patrol({"patrol": "night", "every": "1h"})
    assert everywhen.all_day and everywhen.start == dt.time(0, 0)
    # TOML's own local times are taken too.
    table = {"patrol": "night", "every": "2h", "from": dt.time(22), "to": dt.time(6)}
    assert scheduled_patrol(table) == NIGHT


@pytest.mark.parametrize(
    ("table", "key", "message"),
    [
        ({"every": "2h"}, "patrol", "patrol is missing"),
        ({"patrol": "night"}, "every", "every is missing"),
        ({"patrol": "a b", "every": "2h"}, "patrol", "patrol name 'a b' may use only"),
        ({"patrol": 3, "every": "2h"}, "patrol", "patrol should be a patrol's name"),
        ({"patrol": "n", "every": "0m"}, "every", "every must be a positive time"),
        ({"patrol": "n", "every": "5m"}, "every", "takes longer than that"),
        ({"patrol": "n", "every": "25h"}, "every", "at most 24h"),
        ({"patrol": "n", "every": "2h", "from": "22:00"}, "to", "to is missing"),
        ({"patrol": "n", "every": "2h", "from": "25:00", "to": "6:00"}, "from", "from should"),
        ({"patrol": "n", "every": "2h", "from": "22:00", "to": "6pm"}, "to", "to should be"),
    ],
)
def test_a_table_that_cannot_be_kept_names_its_key(table, key, message):
    with pytest.raises(ScheduleEntryError, match=message) as caught:
        scheduled_patrol(table)
    assert caught.value.key == key
