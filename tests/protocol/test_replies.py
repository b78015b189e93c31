"""Decoding replies: values, lists, set echoes and error lines."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from giraff_console.protocol import (
    ArgumentError,
    BoardError,
    BoardRebootedError,
    GiraffError,
    ProtocolError,
    QueueRolloverError,
    Reply,
    UnknownNameError,
    decode_list,
    format_reply,
    parse_reply,
)

REAL_BULK = (
    "cang:F*00000000,cdis:F*00000000,gvr:F*00000000,tilt_angle_from_home:F*F051B83D,"
    "imdl:F*00000000,imdr:F*00000000,cvg:F*00000000,mode:I*02000000,"
)


def test_real_bulk_capture_decodes_in_order():
    values = parse_reply([REAL_BULK]).value
    assert list(values) == [
        "cang", "cdis", "gvr", "tilt_angle_from_home", "imdl", "imdr", "cvg", "mode",
    ]  # fmt: skip
    assert values["tilt_angle_from_home"] == pytest.approx(0.0900000334, abs=1e-9)
    assert values["mode"] == 2


def test_lists_with_and_without_trailing_comma_agree():
    assert decode_list("but0:I*03000000,but1:I*00000000,dial:I*feffffff,") == decode_list(
        "but0:I*03000000,but1:I*00000000,dial:I*feffffff"
    )
    assert decode_list("but0:3,but1:0,dial:-2") == {"but0": 3, "but1": 0, "dial": -2}


@pytest.mark.parametrize(
    "reply", [["F*cdcccc3e"], ["New Value: F*cdcccc3e"], ["new value:F*cdcccc3e"]]
)
def test_set_echo_forms_all_give_the_value(reply):
    assert parse_reply(reply).value == pytest.approx(0.4)


def test_no_lines_means_no_value():
    assert parse_reply([]).value is None
    assert parse_reply(["", "  "]).value is None


def test_unknown_name_is_typed_and_names_the_parameter():
    with pytest.raises(UnknownNameError) as caught:
        parse_reply(["Unknown name: xyz"])
    assert caught.value.name == "xyz"


@pytest.mark.parametrize(
    ("line", "error"),
    [("ERROR: Queue rollover", QueueRolloverError), ("Error: Unknown argument", ArgumentError),
     ("Error: Argument wasn't optional", ArgumentError), ("ERROR: something else", BoardError)],
)  # fmt: skip
def test_error_lines_are_typed(line, error):
    with pytest.raises(error) as caught:
        parse_reply([line])
    assert caught.value.line == line


@pytest.mark.parametrize("line", ["# Giraf 1.1.112p, 2011-02-20", "Ca>"])
def test_a_banner_mid_session_means_the_board_restarted(line):
    with pytest.raises(BoardRebootedError):
        parse_reply([line])


@pytest.mark.parametrize(
    "lines", [["F*0000803f", "F*0000803f"], ["cang:F*zz"], ["cang"], [","], ["a:1,,b:2"]]
)
def test_unexpected_or_garbled_replies_raise_protocol_error(lines):
    with pytest.raises(ProtocolError):
        parse_reply(lines)


def test_format_reply_decodes_like_the_original():
    assert format_reply("cang:F*0000803f,mode:I*02000000,") == "cang:1.00000,mode:2,"
    assert format_reply("F*0000b442") == "90.00000"
    assert format_reply("Unknown name: x") == "Unknown name: x"


def outcome(lines: list[str]) -> Reply | GiraffError:
    """The reply, or the typed error; any other exception escapes and fails the test."""
    try:
        return parse_reply(lines)
    except GiraffError as error:
        return error


@given(st.binary(max_size=300))
def test_arbitrary_bytes_raise_only_typed_errors(data):
    lines = data.decode("ascii", "replace").replace("\r", "").split("\n")
    assert isinstance(outcome(lines), Reply | GiraffError)


@given(st.text(max_size=200))
def test_arbitrary_text_raises_only_typed_errors(text):
    for candidate in (text, "cang:" + text, "New Value: " + text, "F*" + text, text + ","):
        assert isinstance(outcome([candidate]), Reply | GiraffError)
