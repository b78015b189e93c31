"""Scheduled patrols: when each one is due, and whether to start it (issue 15).

The settings file's `[[schedule]]` tables (settings.py) become `ScheduledPatrol`s. A
schedule runs a patrol at the start of its window, then every `every_s` after that start
while inside the window: 22:00 to 06:00 every 2 h is due at 22:00, 00:00, 02:00, 04:00
and 06:00. The end of the window counts when it falls exactly on that grid (06:00 here);
22:00 to 05:00 every 2 h ends with 04:00. A window whose end is not after its start
wraps midnight; one whose start and end are the same is all day, and its grid starts
again at `start` each day (so the slot at the end, the next day's start, runs once).

Times are the wall clock's local time as naive datetimes, which is what the daemon
passes (`datetime.now()`). Nothing here reads a clock. When the clock is changed for
summer time, the slots in the skipped hour are missed, as after a suspend; the ones in
the repeated hour are not run twice, since each entry only waits for its next due time.

`Scheduler.tick` says, for each slot that has come, whether to start the patrol; the
daemon does the starting. It skips a slot whose patrol is still running from before.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from giraff_console.missions.yaml_file import name_problem, shown

# A patrol of a care home drives every corridor and waits at every room: it takes longer
# than this, so a shorter interval would only pile up skipped slots.
MIN_EVERY_S = 10 * 60.0
# The window repeats each day, so an interval over a day would run daily anyway.
MAX_EVERY_S = 24 * 3600.0
# A slot found this long after its window has ended is not run: the console was asleep
# or off through the whole window. The daemon ticks far more often than this, so a slot
# at the window's end is still run when it is found a moment late.
WINDOW_GRACE = dt.timedelta(minutes=5)

_DAY = dt.timedelta(days=1)
_MICROSECOND = dt.timedelta(microseconds=1)
_DURATION = re.compile(r"(?:(\d{1,3})h)?(?:(\d{1,5})m)?(?:(\d{1,6})s)?\Z")
_CLOCK_TIME = re.compile(r"(\d{1,2}):(\d{2})\Z")


@dataclass(frozen=True)
class ScheduledPatrol:
    """Run the patrol `patrol` (a file in the routes folder) every `every_s` seconds
    from `start` to `end`, local time; start == end: all day."""

    patrol: str
    every_s: float
    start: dt.time
    end: dt.time

    def check(self) -> None:
        """ValueError if this schedule cannot be kept, saying why."""
        problem = name_problem(self.patrol, "patrol")
        if problem is not None:
            raise ValueError(problem)
        if not self.every_s > 0:
            raise ValueError(f"every must be a positive time, not {self.every_s:g} s")
        if self.every_s < MIN_EVERY_S:
            raise ValueError(
                f"every is {_shown_duration(self.every_s)}: it must be at least 10m, since a "
                "patrol of a care home takes longer than that"
            )
        if self.every_s > MAX_EVERY_S:
            raise ValueError(
                f"every is {_shown_duration(self.every_s)}: it must be at most 24h, since the "
                "window repeats each day"
            )

    @property
    def window_s(self) -> float:
        """How long the window lasts: a whole day when start == end."""
        length = _as_delta(self.end) - _as_delta(self.start)
        return (length % _DAY or _DAY).total_seconds()

    @property
    def all_day(self) -> bool:
        return self.start == self.end


class ScheduleEntryError(ValueError):
    """A schedule table that cannot be kept; the message starts with the key at fault
    (`key`), so that the settings file can put its line and table before it."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


def scheduled_patrol(table: Mapping[str, object]) -> ScheduledPatrol:
    """A schedule from a settings table with `patrol`, `every`, and `from` and `to` (both
    or neither: neither is all day). Unknown keys are the caller's to refuse."""
    if "patrol" not in table:
        raise ScheduleEntryError("patrol", "patrol is missing: name a patrol in the routes folder")
    if "every" not in table:
        raise ScheduleEntryError("every", 'every is missing: how often, such as "2h"')
    if ("from" in table) != ("to" in table):
        missing = "to" if "from" in table else "from"
        raise ScheduleEntryError(
            missing, f"{missing} is missing: give both from and to, or neither for all day"
        )
    midnight = dt.time(0, 0)
    patrol = table["patrol"]
    try:
        if not isinstance(patrol, str):
            raise ValueError(f"patrol should be a patrol's name, not {shown(patrol)}")
        entry = ScheduledPatrol(
            patrol,
            parse_every(table["every"]),
            parse_clock_time(table.get("from", midnight), "from"),
            parse_clock_time(table.get("to", midnight), "to"),
        )
        entry.check()
    except ValueError as error:
        # Every message here starts with its key.
        message = str(error)
        raise ScheduleEntryError(message.split(" ", 1)[0], message) from None
    return entry


def parse_every(text: object) -> float:
    """Seconds in a duration such as "2h", "90m", "1h30m" or "45s"; ValueError if not one."""
    match = _DURATION.match(text) if isinstance(text, str) else None
    if match is None or not text:
        raise ValueError(
            f'every should be a duration such as "2h", "90m" or "1h30m", not {shown(text)}'
        )
    hours, minutes, seconds = (int(part or 0) for part in match.groups())
    return float(hours * 3600 + minutes * 60 + seconds)


def parse_clock_time(text: object, key: str) -> dt.time:
    """A time of day, "22:00" (or a TOML local time, 22:00:00); ValueError if not one."""
    if isinstance(text, dt.time) and text.tzinfo is None:
        return text
    match = _CLOCK_TIME.match(text) if isinstance(text, str) else None
    if match is not None:
        hour, minute = int(match[1]), int(match[2])
        if hour < 24 and minute < 60:
            return dt.time(hour, minute)
    raise ValueError(f'{key} should be a local time of day such as "22:00", not {shown(text)}')


def next_due(entry: ScheduledPatrol, after: dt.datetime) -> dt.datetime:
    """The first time strictly after `after` at which `entry` is due (see the module's
    docstring for the grid and the window's end)."""
    every = _whole_microseconds(entry.every_s)
    window = _whole_microseconds(entry.window_s)
    # Windows last at most a day and do not overlap, so the one that opened the day
    # before `after`, or one of the next two, holds the answer: the first found is it.
    for days in (-1, 0, 1, 2):
        opens = dt.datetime.combine(after.date() + dt.timedelta(days=days), entry.start)
        if opens > after:
            return opens
        slot = ((after - opens) // _MICROSECOND) // every + 1
        offset = slot * every
        # The window's end is its last slot, except all day, where it is the next start.
        if offset < window or (offset == window and not entry.all_day):
            return opens + offset * _MICROSECOND
    raise AssertionError("a daily window always has a next slot")  # pragma: no cover


def slots_a_day(entry: ScheduledPatrol) -> int:
    """How many times a day `entry` is due."""
    every = _whole_microseconds(entry.every_s)
    window = _whole_microseconds(entry.window_s)
    if entry.all_day:
        return -(-window // every)  # every slot before the next day's start
    return window // every + 1  # the start, and the end when it falls on the grid


def window_end(entry: ScheduledPatrol, slot: dt.datetime) -> dt.datetime:
    """When the window that `slot` (one of `entry`'s due times) belongs to ends."""
    opens = dt.datetime.combine(slot.date(), entry.start)
    if opens > slot:
        opens -= _DAY
    return opens + dt.timedelta(seconds=entry.window_s)


@dataclass(frozen=True)
class Decision:
    """What to do about a slot that has come: start `entry`'s patrol, or not and why.

    `at` is the slot's due time, the latest that has come; `missed` counts the earlier
    slots passed over without a decision of their own, when the clock jumped past them
    (a suspend, a daemon that was stopped): they are not run one after another. A slot
    found more than WINDOW_GRACE after its window ended is not started either.
    """

    entry: ScheduledPatrol
    at: dt.datetime
    start: bool
    why: str
    missed: int = 0


class Scheduler:
    """The schedule's entries and when each is next due.

    The first due time of each entry is the first after `now`, the time the scheduler
    is made: a daemon started at 23:10 runs a 22:00-06:00 every 2 h patrol first at
    00:00, not at once for the 22:00 slot it was not there for.
    """

    def __init__(self, entries: Iterable[ScheduledPatrol], now: dt.datetime) -> None:
        self.entries = tuple(entries)
        self._next = [next_due(entry, now) for entry in self.entries]

    def upcoming(self) -> list[tuple[ScheduledPatrol, dt.datetime]]:
        """Each entry with its next due time, soonest first."""
        return sorted(zip(self.entries, self._next, strict=True), key=lambda pair: pair[1])

    def tick(self, now: dt.datetime, running: Callable[[str], bool]) -> list[Decision]:
        """Decisions for the slots that have come since the last tick.

        `running(name)` says whether the patrol `name` is still running from an earlier
        start: the slot is then skipped, not queued, since a patrol that overruns its
        interval would otherwise start again the moment it ends, all night.
        """
        decisions: list[Decision] = []
        for index, entry in enumerate(self.entries):
            due = self._next[index]
            if now < due:
                continue
            # Every slot that has come, counted to find the latest: whole days at once
            # (a clock set from 1970 by NTP jumps decades), then one by one.
            missed = 0
            days = (now - due).days - 1
            if days > 0:
                due += dt.timedelta(days=days)  # the same slot, days later: the grid is daily
                missed += days * slots_a_day(entry)
            following = next_due(entry, due)
            while following <= now:
                due, following, missed = following, next_due(entry, following), missed + 1
            self._next[index] = following
            # Two entries for one patrol due at once start it once.
            starting = {d.entry.patrol for d in decisions if d.start}
            decision = self._decide(entry, due, now, missed, running)
            if decision.start and entry.patrol in starting:
                why = f"{entry.patrol} is starting now for another schedule entry"
                decision = Decision(entry, due, False, why, missed)
            decisions.append(decision)
        return decisions

    def _decide(
        self,
        entry: ScheduledPatrol,
        due: dt.datetime,
        now: dt.datetime,
        missed: int,
        running: Callable[[str], bool],
    ) -> Decision:
        passed = f"{missed} earlier run{'s' if missed != 1 else ''} missed" if missed else ""
        slot = due.strftime("%H:%M")
        if now > window_end(entry, due) + WINDOW_GRACE:
            # A night patrol is not started in the morning among the residents because
            # the console was asleep all night.
            runs = missed + 1
            return Decision(
                entry, due, False,
                f"the {entry.start:%H:%M}-{entry.end:%H:%M} window of {entry.patrol} had "
                f"passed when the console woke ({runs} run{'s' if runs != 1 else ''} missed)",
                missed,
            )  # fmt: skip
        if running(entry.patrol):
            why = f"the previous run of {entry.patrol} has not finished"
            return Decision(entry, due, False, f"{why}; {passed}" if passed else why, missed)
        why = f"due at {slot}"
        if passed:
            why += f"; {passed} (the clock jumped, or the console was not running)"
        return Decision(entry, due, True, why, missed)


def _as_delta(time: dt.time) -> dt.timedelta:
    return dt.timedelta(
        hours=time.hour, minutes=time.minute, seconds=time.second, microseconds=time.microsecond
    )


def _whole_microseconds(seconds: float) -> int:
    return max(1, round(seconds * 1_000_000))


def _shown_duration(seconds: float) -> str:
    whole = round(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    shown = (f"{hours}h" if hours else "") + (f"{minutes}m" if minutes else "")
    shown += f"{secs}s" if secs or not shown else ""
    return shown
