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
from giraff_console.protocol.codec import TWM_SETTINGS, names_set, settings_of

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


# -- Giraff-X's twm: a whole curved move in one `set` (wire-facts, "Later firmware") ----


def test_a_twm_is_one_set_with_six_values():
    command = parse_command("set twm 0.3 0.2 1 0.25 0.2 0")
    assert command == Command("set", "twm", (0.3, 0.2, 1, 0.25, 0.2, 0))
    assert command.values == (0.3, 0.2, 1, 0.25, 0.2, 0)
    assert command.wire == b"set twm 0.3 0.2 1 0.25 0.2 0\r"
    assert encode_set("twm", (-0.5, 0.1, -2, 0.4, 1e-05, 0)) == (
        b"set twm -0.5 0.1 -2 0.4 0.00001 0\r"
    )


def test_each_value_of_a_twm_goes_out_as_format_number_writes_it():
    values = (-0.1234567891234, 1e-05, 2.0, 0.30000000000000004, -0.0, 0)
    text = Command("set", "twm", values).text
    assert text.split()[2:] == [format_number(value) for value in values]


def test_a_twm_typed_in_any_case_is_the_board_s_spelling():
    assert parse_command("SET TWM 0.1 0 1 0.2 0.1 0").text == "set twm 0.1 0 1 0.2 0.1 0"


def test_a_twm_sets_the_five_settings_it_carries():
    command = parse_command("set twm -0.3 0.2 -1 0.25 0.15 0")
    assert command.settings == {"vg": "-0.3", "cdp": "0.2", "vgr": "-1", "v": "0.25",
                                "p": "0.15"}  # fmt: skip
    assert settings_of("twm", "0.1 0 1 0.2 0.1 0")["p"] == "0.1"
    assert parse_command("set v 0.3").settings == {"v": "0.3"}
    assert parse_command("get v").settings == {}
    assert names_set("twm") == TWM_SETTINGS
    assert names_set("v") == ("v",)


@pytest.mark.parametrize(
    "text",
    ["set twm", "set twm 0.1", "set twm 0.1 0 1 0.2 0.1", "set twm 0.1 0 1 0.2 0.1 0 0",
     "set twm 0.1 0 1 0.2 x 0", "set twm 0.1 0 1 0.2 nan 0", "set v 0.3 0.4",
     "set p 0.1 0.1 0.1 0.1 0.1 0", "set twm 0.1 0 1 0.2 0.1 0\rset p 9"],
)  # fmt: skip
def test_only_twm_takes_several_values_and_exactly_six(text):
    with pytest.raises(CommandError):
        parse_command(text)


@pytest.mark.parametrize(
    ("name", "value"),
    [("twm", 0.1), ("twm", (0.1, 0, 1, 0.2, 0.1)), ("v", (0.1,)), ("p", (0.1, 0.2))],
)
def test_a_command_with_the_wrong_number_of_values_cannot_be_built(name, value):
    with pytest.raises(CommandError):
        Command("set", name, value)


def test_settings_of_refuses_text_with_the_wrong_number_of_values():
    with pytest.raises(CommandError):
        settings_of("twm", "0.1 0.2")
    with pytest.raises(CommandError):
        settings_of("v", "0.1 0.2")


@given(st.tuples(*[st.floats(-1e6, 1e6) | st.integers(-(10**6), 10**6)] * 6))
def test_a_twm_reads_back_as_it_was_written(values):
    command = Command("set", "twm", values)
    again = parse_command(command.text)
    assert again.text == command.text
    assert list(again.settings.values()) == command.text.split()[2:7]
