"""Parsing hand-written YAML: every failure is a YamlSourceError at a line, never a
crash of the C parser or a traceback."""

from __future__ import annotations

import pytest

from giraff_console.yaml_source import MAX_NESTING, YamlSourceError, parse_yaml, too_deep


@pytest.mark.parametrize(
    "data",
    [b"[" * 1_000_000, b"a: " + b"{a: " * 100_000, b"- " * 100_000, b"x:\n" + b" " * 200 + b"y: 1"],
)
def test_nesting_past_the_bound_is_refused_before_parsing(data):
    # libyaml recurses in C: a million `[` would crash the process, not raise.
    with pytest.raises(YamlSourceError, match=f"nested more than {MAX_NESTING}"):
        parse_yaml(data)


def test_the_example_floor_plan_is_far_from_the_bound():
    assert too_deep("rooms:\n  lobby:\n    outline: [[-4, 8], [0, 8], [0, 19]]\n") is None


@pytest.mark.parametrize(
    ("data", "line", "message"),
    [
        (b"format: 1\n\xff\n", 2, "not UTF-8 text (byte 0xff)"),
        (b"a: 1\nb: [\n", 3, "not YAML"),
        (b"taught: 2024-13-45\n", None, "not YAML this console reads: month must be in 1..12"),
        (b"n: " + b"9" * 5000 + b"\n", None, "not YAML this console reads"),
    ],
)
def test_bytes_that_are_not_yaml_name_the_line_where_it_is_known(data, line, message):
    with pytest.raises(YamlSourceError) as refused:
        parse_yaml(data)
    assert refused.value.line == line
    assert refused.value.message.startswith(message)
