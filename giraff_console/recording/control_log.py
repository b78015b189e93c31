"""The session log in the original console's text format (§3.2.1.1, B.2).

Every exchange with the board is one line, prefixed by the seconds since recording
started:

    `%8.3f:[F] param: reply <= orig`

The flag is `S` for a set, `G` for a get, `C` for a bare command, and a space for the
automatic `bulk_data` poll (the original's silent get). Replies are decoded as the
original's FormatReply did: hex fields become decimals, names and commas are copied.
`orig` is the value a set sent, as typed on the wire. The original's playback reads
these lines back (B.2 PlaybackData), and so does `read_log`, which also reads logs the
original wrote.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, TypeVar

from giraff_console.file_limits import read_bounded
from giraff_console.link.exchange import Exchange
from giraff_console.protocol.replies import format_reply

FLAGS = {"set": "S", "get": "G", "command": "C"}
AUTOMATIC = " "
# `%8.3f:[F] ` then the parameter: the original's parser takes the flag at index 2 of
# what follows the number, and the parameter from index 5 (B.2 PlaybackData).
_LINE = re.compile(r"\s*(?P<offset>[-+0-9.eE]+):\[(?P<flag>[SGC ])\] (?P<rest>.*)\Z")


@dataclass(frozen=True)
class LogEntry:
    """One line of a session log."""

    offset: float
    flag: str
    param: str
    reply: str
    orig: str = ""
    line_no: int = 0

    @property
    def command(self) -> str:
        """The command as it went on the wire: `set v 0.3`, `get v`, `home`."""
        if self.flag == "S":
            return f"set {self.param} {self.orig}".rstrip()
        if self.flag in ("G", AUTOMATIC):
            return f"get {self.param}"
        return self.param

    @property
    def automatic(self) -> bool:
        return self.flag == AUTOMATIC

    @property
    def frame_marker(self) -> bool:
        """The original polled bulk_data right after each camera frame (§3.2.1.1)."""
        return self.flag == AUTOMATIC and self.param == "bulk_data"


@dataclass(frozen=True)
class LogProblem:
    """A line that could not be played, and why."""

    line_no: int
    reason: str

    def __str__(self) -> str:
        return f"line {self.line_no}: {self.reason}"


@dataclass(frozen=True)
class LogRead:
    """What `read_log` found: the playable entries, and the lines it skipped."""

    entries: list[LogEntry]
    problems: list[LogProblem]

    @property
    def duration(self) -> float:
        return self.entries[-1].offset if self.entries else 0.0


def entry_for(exchange: Exchange, start: float) -> LogEntry | None:
    """The log entry for an exchange, or None for one the format has no line for.

    Greetings and resynchronisations are the link's own business, and an exchange that
    got no reply at all (a timeout) has nothing to decode; the status log reports those.
    """
    if exchange.kind not in FLAGS or (exchange.error is not None and not exchange.lines):
        return None
    flag = AUTOMATIC if exchange.automatic else FLAGS[exchange.kind]
    words = exchange.command.split()
    if exchange.kind == "set":
        param, orig = words[1], " ".join(words[2:])
    elif exchange.kind == "get":
        param, orig = words[1], ""
    else:
        param, orig = exchange.command, ""
    reply = " / ".join(format_reply(line) for line in exchange.lines)
    return LogEntry(exchange.answered_at - start, flag, param, reply, orig)


def format_entry(entry: LogEntry) -> str:
    """One log line, without its line end (B.2 RecordParameter)."""
    line = f"{entry.offset:8.3f}:[{entry.flag}] {entry.param}: {entry.reply}"
    if entry.orig:
        line += f" <= {entry.orig}"
    return line


def parse_entry(text: str, line_no: int = 0) -> LogEntry:
    """Parse one log line; ValueError says what is wrong with it."""
    match = _LINE.match(text.rstrip("\r\n"))
    if match is None:
        raise ValueError("not a log line (expected `seconds:[F] param: reply`)")
    try:
        offset = float(match.group("offset"))
    except ValueError:
        raise ValueError(f"bad time {match.group('offset')!r}") from None
    if not math.isfinite(offset) or offset < 0:
        raise ValueError(f"bad time {match.group('offset')!r}")
    param, separator, rest = match.group("rest").partition(": ")
    if not separator:
        # A bare command recorded with no reply ends in ":" with nothing after it.
        if not match.group("rest").endswith(":"):
            raise ValueError("no `: ` after the parameter")
        param, rest = match.group("rest")[:-1], ""
    if not param or (" " in param.strip() and match.group("flag") != "C"):
        raise ValueError(f"bad parameter {param!r}")
    reply, _, orig = rest.partition(" <= ")
    return LogEntry(offset, match.group("flag"), param, reply, orig, line_no)


def read_log(path: Path) -> LogRead:
    """Every playable line of a log; corrupt lines are reported and skipped.

    A session cut off by a crash or a power loss may end in half a line: that line is
    reported and everything before it plays. Times must not go backwards, since playback
    keeps to them; a line that does is reported and skipped. OSError (FileRefused) for a
    file that is not a regular one, or larger than the `log_bytes` limit.
    """
    data = read_bounded(path, "log_bytes")
    return parse_log(data.decode("utf-8", "replace").split("\n"))


def parse_log(lines: Iterable[str]) -> LogRead:
    """`read_log` on lines already read; the last one is the text after the last line end."""
    entries, problems = parse_lines(lines, parse_entry)
    return LogRead(entries, problems)


class Timed(Protocol):
    @property
    def offset(self) -> float: ...


TimedEntry = TypeVar("TimedEntry", bound=Timed)


def parse_lines(
    lines: Iterable[str], parse: Callable[[str, int], TimedEntry]
) -> tuple[list[TimedEntry], list[LogProblem]]:
    """Every line of a recording's file that `parse(text, line_no)` takes, in time order;
    a line it refuses (ValueError), one whose time goes backwards and the last, unfinished
    one (the text after the last line end) are reported and skipped."""
    entries: list[TimedEntry] = []
    problems: list[LogProblem] = []
    lines = list(lines)
    last = len(lines)
    for line_no, text in enumerate(lines, start=1):
        if not text.strip():
            continue
        if line_no == last:
            # No line end after it: the recording stopped while writing this line.
            problems.append(LogProblem(line_no, "incomplete last line, ignored"))
            break
        try:
            entry = parse(text, line_no)
        except ValueError as error:
            problems.append(LogProblem(line_no, f"{error}; skipped"))
            continue
        if entries and entry.offset < entries[-1].offset:
            problems.append(LogProblem(line_no, "time goes backwards; skipped"))
            continue
        entries.append(entry)
    return entries, problems
