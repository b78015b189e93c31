"""The log of patrol runs: one JSON-lines file per run, written as the run goes (issue 15).

The daemon keeps them in `<data folder>/patrol-runs/`; `giraff-console patrols --json`
lists them (`list_runs`). A run's file is `<UTC start>-<patrol>.jsonl`, for example
`20250101T220000Z-night.jsonl`, and holds one JSON object a line:

    {"event": "start", "patrol": "night", "at": "2025-01-01T23:00:00+01:00",
     "scheduled": true, "by": "schedule"}
    {"event": "stop", "at": ..., ...the stop's record, as the caller gives it}
    {"event": "snapshot", "at": ..., "path": "/.../snapshot.png"}
    {"event": "end", "at": ..., "why": "done", "arrived": true, "stops": 6}

A slot the schedule skipped has a file of one line, {"event": "skipped", "patrol", "at",
"scheduled", "by", "why"}, so that the log shows it. Times are local with their offset.

Each line goes out in one write, with no buffer in between, and the end is fsync'd: a
daemon killed mid-run leaves every line it wrote, and the run reads as unfinished.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import math
import os
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from giraff_console.file_limits import read_bounded
from giraff_console.private_files import PRIVATE_FILE, private_folder

RUNS_FOLDER = "patrol-runs"
SUFFIX = ".jsonl"
UNFINISHED = "unfinished (the daemon stopped during it)"
RUNNING = "running"
_UNSAFE = re.compile(r"[^A-Za-z0-9_-]")
# Garbled lines noted in a summary; more are counted, not listed.
MAX_NOTES = 5

Now = Callable[[], dt.datetime]
# Makes a run's file and returns a descriptor open for writing; FileExistsError if the
# name is taken. A seam for tests, which hand it /dev/full to fill the disk.
Opener = Callable[[Path], int]


def _local_now() -> dt.datetime:
    return dt.datetime.now().astimezone()


def _create(path: Path) -> int:
    return os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, PRIVATE_FILE)


class PatrolRunLog:
    """One patrol run's file, written a line at a time.

    No method raises for a failed write (a full disk, a folder that is not writable):
    the robot patrolling the home matters more than its log, and an exception here
    would reach the control loop and stop the patrol. The first failure is kept in
    `problem` and each method returns the text of its own failure (None when it wrote).
    """

    def __init__(self, folder: Path, now: Now = _local_now, opener: Opener = _create) -> None:
        self.folder = Path(folder)
        self.path: Path | None = None
        self.problem: str | None = None
        self._now, self._opener = now, opener
        self._fd: int | None = None
        # A write that failed part way leaves a line without its newline; the next
        # line starts with one, so that only the broken line is lost.
        self._broken = False
        # Stops are logged on the control loop's thread, snapshots where they are saved.
        self._lock = threading.Lock()

    def start(self, patrol: str, *, scheduled: bool, by: str) -> str | None:
        """Open the run's file with its first line."""
        with self._lock:
            return self._first("start", patrol, {"scheduled": scheduled, "by": by})

    def stop(self, record: dict[str, Any]) -> str | None:
        """A line for a stop: the caller's record of it (route_book.py's RunLog)."""
        line: dict[str, Any] = {"event": "stop", "at": _stamp(self._now())}
        line.update(record)
        line["event"] = "stop"
        with self._lock:
            return self._write(line)

    def snapshot(self, path: Path | str) -> str | None:
        with self._lock:
            return self._write({"event": "snapshot", "at": _stamp(self._now()), "path": str(path)})

    def end(self, why: str, arrived: bool, stops: int) -> str | None:
        """The last line, fsync'd, and the file closed."""
        line = {"event": "end", "at": _stamp(self._now()), "why": why, "arrived": arrived,
                "stops": stops}  # fmt: skip
        with self._lock:
            problem = self._write(line)
            problem = self._close() or problem
            return problem

    def skipped(self, patrol: str, why: str, *, by: str = "schedule") -> str | None:
        """A run file of one line, for a slot the schedule skipped: the log shows it."""
        with self._lock:
            if self._fd is not None:  # a run under way here is not this one to close
                return self._fail(f"a run is already being logged in {self.path}")
            problem = self._first("skipped", patrol, {"scheduled": True, "by": by, "why": why})
            return self._close() or problem

    # Under the lock.

    def _first(self, event: str, patrol: str, fields: dict[str, Any]) -> str | None:
        """Make the run's file and write its first line; the problem if either fails."""
        if self._fd is not None:
            return self._fail(f"a run is already being logged in {self.path}")
        at = self._now()
        failed = self._open(patrol, at)
        if failed is not None:
            return failed
        return self._write({"event": event, "patrol": patrol, "at": _stamp(at), **fields})

    def _open(self, patrol: str, at: dt.datetime) -> str | None:
        """Make the run's file; the problem if it cannot be made."""
        base = f"{at.astimezone(dt.UTC):%Y%m%dT%H%M%SZ}-{_UNSAFE.sub('_', patrol)[:64]}"
        try:
            # The log names the residents' rooms and their pictures: only the operator
            # may read it.
            private_folder(self.folder)
            # Two runs started in the same second (a skipped slot and a run) get their
            # own files.
            for attempt in range(1, 100):
                path = self.folder / f"{base}{f'-{attempt}' if attempt > 1 else ''}{SUFFIX}"
                try:
                    self._fd = self._opener(path)
                except FileExistsError:
                    continue
                self.path, self._broken = path, False
                return None
            return self._fail(f"cannot make a run file in {self.folder}: every name is taken")
        except OSError as error:
            return self._fail(f"cannot make a run file in {self.folder}: {_reason(error)}")

    def _write(self, line: dict[str, Any]) -> str | None:
        if self._fd is None:
            return self.problem or self._fail("the run's log was not started")
        data = json.dumps(_finite(line), allow_nan=False, default=str).encode() + b"\n"
        if self._broken:
            data = b"\n" + data
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
        except OSError as error:
            self._broken = True
            return self._fail(f"cannot write to {self.path}: {_reason(error)}")
        self._broken = False
        return None

    def _close(self) -> str | None:
        if self._fd is None:
            return None
        fd, self._fd = self._fd, None
        try:
            os.fsync(fd)
        except OSError as error:
            return self._fail(f"cannot save {self.path} to disk: {_reason(error)}")
        finally:
            with contextlib.suppress(OSError):
                os.close(fd)
        return None

    def _fail(self, message: str) -> str:
        self.problem = self.problem or message
        return message


@dataclass(frozen=True)
class RunSummary:
    """One run as `giraff-console patrols` lists it.

    `state` is "ended", "skipped", "running" or "unfinished"; `arrived` is None unless
    the run ended; `stops` and `snapshots` are counts (the run's file has the details);
    `notes` says which lines of the file could not be read.
    """

    patrol: str
    started: str | None
    ended: str | None
    why: str
    scheduled: bool | None
    by: str | None
    stops: int
    arrived: bool | None
    snapshots: int
    file: str
    state: str
    notes: tuple[str, ...] = field(default=())

    def line(self) -> str:
        """The run in words, as `giraff-console patrols` prints it."""
        reached = {True: ", every stop reached", False: ", not every stop reached",
                   None: ""}[self.arrived]  # fmt: skip
        stops = f"{self.stops} stop{'' if self.stops == 1 else 's'}"
        return (f"{self.started or '?'}  {self.patrol}  by {self.by or '?'}: {self.state}, "
                f"{stops}{reached}; {self.why}")  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        return {
            "patrol": self.patrol,
            "started": self.started,
            "ended": self.ended,
            "why": self.why,
            "scheduled": self.scheduled,
            "by": self.by,
            "stops": self.stops,
            "arrived": self.arrived,
            "snapshots": self.snapshots,
            "file": self.file,
            "state": self.state,
            "notes": list(self.notes),
        }


def list_runs(
    folder: Path, limit: int | None = None, running: Path | None = None
) -> list[RunSummary]:
    """The runs logged in `folder`, newest first (at most `limit`); none without it.

    A run without an end line is unfinished, unless its file is `running`, the run the
    daemon has under way. Lines that cannot be read are noted, never raised.
    """
    try:
        paths = sorted(Path(folder).glob(f"*{SUFFIX}"), key=lambda path: path.name, reverse=True)
    except OSError:
        return []
    if limit is not None:
        paths = paths[: max(limit, 0)]
    is_running = (lambda path: False) if running is None else _same_file(Path(running))
    return [_summary(path, is_running(path)) for path in paths]


def _summary(path: Path, running: bool) -> RunSummary:
    found: dict[str, Any] = {"stops": 0, "snapshots": 0}
    notes: list[str] = []
    bad = 0
    try:
        lines = read_bounded(path, "log_bytes").split(b"\n")
    except OSError as error:
        lines = []
        notes.append(f"cannot read it: {_reason(error)}")
    for number, raw in enumerate(lines, start=1):
        if not raw.strip():
            continue
        try:
            line = json.loads(raw)
            if not isinstance(line, dict) or not isinstance(line.get("event"), str):
                raise ValueError("not an event")
        except (ValueError, RecursionError):
            # A truncated last line (killed mid-write) or a full disk's broken line.
            bad += 1
            if bad <= MAX_NOTES:
                notes.append(f"line {number} could not be read and was skipped")
            continue
        _take(found, line)
    if bad > MAX_NOTES:
        notes.append(f"{bad - MAX_NOTES} more lines could not be read")
    patrol = _text(found.get("patrol")) or _patrol_from_name(path.name)
    if found.get("skipped"):
        state, ended, why = "skipped", _text(found.get("started")), found.get("why")
    elif "end" in found:
        state, ended, why = "ended", _text(found["end"].get("at")), found["end"].get("why")
    elif running:
        state, ended, why = "running", None, RUNNING
    else:
        state, ended, why = "unfinished", None, UNFINISHED
    end = found.get("end", {})
    stops = end.get("stops")
    if not isinstance(stops, int) or isinstance(stops, bool) or stops < 0:
        stops = found["stops"]
    arrived = end.get("arrived")
    scheduled = found.get("scheduled")
    return RunSummary(
        patrol=patrol, started=_text(found.get("started")), ended=ended,
        why=_text(why) or state, scheduled=scheduled if isinstance(scheduled, bool) else None,
        by=_text(found.get("by")), stops=stops,
        arrived=arrived if isinstance(arrived, bool) else None,
        snapshots=found["snapshots"], file=str(path), state=state, notes=tuple(notes),
    )  # fmt: skip


def _take(found: dict[str, Any], line: dict[str, Any]) -> None:
    event = line["event"]
    if event in ("start", "skipped"):
        found.update(patrol=line.get("patrol"), started=line.get("at"),
                     scheduled=line.get("scheduled"), by=line.get("by"))  # fmt: skip
        if event == "skipped":
            found.update(skipped=True, why=line.get("why"))
    elif event == "stop":
        found["stops"] += 1
    elif event == "snapshot":
        found["snapshots"] += 1
    elif event == "end":
        found["end"] = line


def _same_file(running: Path) -> Callable[[Path], bool]:
    def same(path: Path) -> bool:
        try:
            return path.samefile(running)
        except OSError:
            return path == running

    return same


def _patrol_from_name(name: str) -> str:
    stem = name.removesuffix(SUFFIX)
    return stem.split("-", 1)[1] if "-" in stem else stem


def _text(value: object) -> str | None:
    return value if isinstance(value, str) else None


def _stamp(at: dt.datetime) -> str:
    """ISO local time with its offset; a naive time is taken as the machine's local time."""
    return (at if at.tzinfo is not None else at.astimezone()).isoformat(timespec="seconds")


def _reason(error: OSError) -> str:
    return error.strerror or str(error)


def _finite(value: Any) -> Any:
    """`value` with NaN and infinities as null: a pose that is not known is written so
    that any JSON reader takes it, not as Python's NaN."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(key): _finite(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item) for item in value]
    return value
