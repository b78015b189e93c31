"""Encoding commands and values, decoding values (Appendix A.3, wire-facts)."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from giraff_console.protocol import (
    Command,
    CommandError,
    ProtocolError,
    decode_value,
    encode_command,
    encode_float,
    encode_get,
    encode_int,
    encode_set,
    format_number,
    parse_command,
)

# The checked vectors of wire-facts.md.
WIRE_FACT_VECTORS = [
    ("F*0000803f", 1.0),
    ("F*000080bf", -1.0),
    ("F*cdcccc3d", struct.unpack("<f", struct.pack("<f", 0.1))[0]),
    ("F*9a99193f", struct.unpack("<f", struct.pack("<f", 0.6))[0]),
    ("F*0000b442", 90.0),
    ("F*db0f4940", 3.14159274),
    ("I*02000000", 2),
    ("I*29000000", 41),
    ("I*ffffffff", -1),
    ("I*e8030000", 1000),
]


@pytest.mark.parametrize(("text", "value"), WIRE_FACT_VECTORS)
def test_wire_fact_vectors_decode(text, value):
    assert decode_value(text) == pytest.approx(value, rel=1e-7)


@pytest.mark.parametrize(("text", "value"), WIRE_FACT_VECTORS)
def test_hex_case_does_not_matter(text, value):
    assert decode_value(text[:2] + text[2:].upper()) == decode_value(text)


@pytest.mark.parametrize(("text", "value"), WIRE_FACT_VECTORS)
def test_wire_fact_vectors_encode(text, value):
    encoded = encode_int(value) if text.startswith("I") else encode_float(value)
    assert encoded == text


def test_integers_decode_as_int_and_floats_as_float():
    assert isinstance(decode_value("I*02000000"), int)
    assert isinstance(decode_value("F*0000803f"), float)


@given(st.floats(width=32, allow_nan=False))
def test_float32_round_trips(value):
    assert decode_value(encode_float(value)) == value


@given(st.integers(min_value=-(2**31), max_value=2**31 - 1))
def test_int32_round_trips(value):
    assert decode_value(encode_int(value)) == value


def test_plain_ascii_numbers_decode():
    assert decode_value("42") == 42
    assert decode_value("-0.25") == -0.25


@pytest.mark.parametrize("text", ["", "F*", "F*0000803", "F*0000803g", "X*00000000", "1.2.3", "OK"])
def test_garbled_values_raise_protocol_error(text):
    with pytest.raises(ProtocolError):
        decode_value(text)


@pytest.mark.parametrize(
    ("value", "text"),
    [(1e-05, "0.00001"), (0.1, "0.1"), (1.0, "1"), (-0.5, "-0.5"), (0.0, "0"), (-0.0, "0"),
     (123456789.0, "123456789"), (1.5e-10, "0"), (-1e-12, "0"), (0.1234567891234, "0.123456789"),
     (7, "7"), (-3, "-3")],
)  # fmt: skip
def test_numbers_go_out_as_plain_decimals(value, text):
    assert format_number(value) == text


@given(st.floats(min_value=-1e9, max_value=1e9, exclude_min=True, exclude_max=True))
def test_formatted_numbers_are_short_plain_and_read_back_to_nine_decimals(value):
    text = format_number(value)
    assert "e" not in text.lower()
    assert len(text) <= 20
    assert abs(float(text) - value) <= 5e-10 * max(1.0, abs(value))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, True, "1", 1e9, -2e12, 10**10])
def test_non_numbers_are_refused(value):
    with pytest.raises(CommandError):
        format_number(value)


def test_floats_beyond_float32_encode_as_infinity():
    assert decode_value(encode_float(1e39)) == math.inf
    assert decode_value(encode_float(-1e39)) == -math.inf


def test_commands_encode_with_cr_only():
    assert encode_set("v", 0.3) == b"set v 0.3\r"
    assert encode_set("p", 1e-05) == b"set p 0.00001\r"
    assert encode_get("bulk_data") == b"get bulk_data\r"
    assert encode_command("home") == b"home\r"


def test_parse_command_accepts_the_three_forms():
    assert parse_command("set v 0.3") == Command("set", "v", 0.3)
    assert parse_command("  get   bulk_data ") == Command("get", "bulk_data")
    assert parse_command("home") == Command("command", "home")
    assert parse_command("set mode 4").value == 4


@pytest.mark.parametrize(
    "text",
    ["set v 0.3\rset p 10", "get v\nhome", "set v", "set v abc", "set v 0.3 p", "get",
     "get a b", "home now", "", "   ", "set v;p 1", "get vélocité", "set v nan", "set v inf",
     "get x\x00"],
)  # fmt: skip
def test_parse_command_refuses_anything_but_one_command(text):
    with pytest.raises(CommandError):
        parse_command(text)


@pytest.mark.parametrize("name", ["v p", "v\r", "", "1v", "v;", "ß"])
def test_command_names_cannot_smuggle_bytes(name):
    with pytest.raises(CommandError):
        Command("get", name)
