"""The session log: the original's line format, written and read back, bad lines reported."""

from __future__ import annotations

from pathlib import Path

import pytest

from giraff_console.link import Exchange
from giraff_console.protocol.errors import UnknownNameError
from giraff_console.recording.control_log import (
    LogEntry,
    entry_for,
    format_entry,
    parse_entry,
    read_log,
)

ORIGINAL = Path(__file__).parent / "fixtures" / "original_console.txt"


def exchange(kind, command, lines, automatic=False, error=None, at=12.5):
    return Exchange(kind, command, tuple(lines), None, error, at - 0.01, at, automatic)


def test_a_set_is_written_as_the_original_wrote_it():
    entry = entry_for(exchange("set", "set v 0.3", ["F*9a99993e"]), start=10.0)
    assert format_entry(entry) == "   2.500:[S] v: 0.30000 <= 0.3"


def test_the_automatic_poll_has_a_blank_flag_and_every_field_decoded():
    reply = "cdis:F*0000803f,mode:I*80000000,"
    entry = entry_for(exchange("get", "get bulk_data", [reply], automatic=True), start=12.0)
    assert format_entry(entry) == "   0.500:[ ] bulk_data: cdis:1.00000,mode:128,"
    assert entry.frame_marker


def test_gets_and_bare_commands_have_their_flags():
    got = entry_for(exchange("get", "get v", ["F*9a99993e"]), start=0.0)
    home = entry_for(exchange("command", "home", []), start=0.0)
    assert format_entry(got) == "  12.500:[G] v: 0.30000"
    assert format_entry(home) == "  12.500:[C] home: "


def test_a_board_error_is_kept_but_a_timeout_has_no_line():
    refused = exchange("get", "get x", ["Unknown name: x"], error=UnknownNameError("", "x"))
    assert format_entry(entry_for(refused, 0.0)).endswith("[G] x: Unknown name: x")
    timed_out = exchange("get", "get v", [], error=TimeoutError())
    assert entry_for(timed_out, 0.0) is None
    assert entry_for(exchange("resync", "sync_1234", []), 0.0) is None


@pytest.mark.parametrize(
    "entry",
    [
        LogEntry(0.0, "S", "p", "0.28800", "0.288"),
        LogEntry(1.25, "G", "bulk_data", "cang:0.00000,mode:0,"),
        LogEntry(3601.5, "C", "home", ""),
        LogEntry(7.0, " ", "bulk_data", "cdis:1.00000,"),
    ],
)
def test_every_entry_reads_back_as_written(entry):
    assert parse_entry(format_entry(entry)) == entry


def test_a_log_of_the_original_console_reads_whole():
    log = read_log(ORIGINAL)
    assert log.problems == []
    assert len(log.entries) == 37
    assert [e.command for e in log.entries[1:8]] == [
        "home", "get v", "set r 1000", "set mode 0", "set a 0.5", "set v 0.3", "set p 0.6",
    ]  # fmt: skip
    assert sum(e.frame_marker for e in log.entries) == 30


def test_a_truncated_last_line_is_reported_and_the_rest_plays(tmp_path):
    text = ORIGINAL.read_text()
    cut = tmp_path / "cut.txt"
    cut.write_text(text[: len(text) - 40])  # kill -9 in the middle of the last line
    log = read_log(cut)
    assert len(log.entries) == 36
    assert [str(p) for p in log.problems] == ["line 37: incomplete last line, ignored"]


def test_a_garbage_line_is_reported_with_its_number_and_skipped(tmp_path):
    lines = ORIGINAL.read_text().splitlines(keepends=True)
    lines[4] = "\x00\x17garbage from a bad sector\n"
    lines[9] = "   9.999:[S] p 0.3\n"  # no ": "
    bad = tmp_path / "bad.txt"
    bad.write_text("".join(lines))
    log = read_log(bad)
    assert len(log.entries) == 35
    assert [p.line_no for p in log.problems] == [5, 10]
    assert "not a log line" in str(log.problems[0])


def test_time_going_backwards_is_reported(tmp_path):
    path = tmp_path / "back.txt"
    path.write_text("   1.000:[G] v: 0.3\n   0.500:[G] v: 0.3\n   1.500:[G] v: 0.3\n")
    log = read_log(path)
    assert [e.offset for e in log.entries] == [1.0, 1.5]
    assert [p.line_no for p in log.problems] == [2]
