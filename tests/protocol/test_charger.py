"""The charger's own encoding (wire-facts "Later firmware"): read, written, and refused."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from giraff_console.protocol import ProtocolError, parse_reply
from giraff_console.protocol.charger import (
    PARAMETERS,
    ChargerReading,
    ChargeStatus,
    crc16_ccitt_false,
    format_charger,
    parse_charger,
)


def test_status_digits_are_the_drivers():
    assert [status.value for status in ChargeStatus] == [0, 1, 2, 3, 4]
    assert ChargeStatus(4) is ChargeStatus.NOT_DOCKED
    assert ChargeStatus(0) is ChargeStatus.FAST_CHARGING


def test_a_float_parameter_reads_little_endian():
    # 25.1 as a float32 is 0x41c8cccd; least significant byte first, as in F*.
    reading = parse_charger("S:S#4,B:F#cdccc841 U#c931")
    assert reading == ChargerReading(ChargeStatus.NOT_DOCKED, "B", pytest.approx(25.1))


def test_watt_seconds_read_as_a_signed_integer():
    reading = parse_charger("S:S#0,W:I#c7cfffff U#0000")
    assert reading.status is ChargeStatus.FAST_CHARGING
    assert reading.parameter == "W"
    assert reading.value == -12345


def test_any_checksum_and_either_hex_case_are_accepted():
    # The checksum's algorithm on real boards is undocumented: the console ignores it.
    assert parse_charger("S:S#1,t:F#0000C841 U#FFFF").value == 25.0
    assert parse_charger("  S:S#1,t:F#0000c841 U#beef\r\n").value == 25.0


def test_a_status_that_ends_in_a_digit_counts_by_that_digit():
    assert parse_charger("S:S#04,b:F#0000c0bf U#1234").status is ChargeStatus.NOT_DOCKED


@pytest.mark.parametrize("parameter", PARAMETERS)
@pytest.mark.parametrize("status", list(ChargeStatus))
def test_what_the_simulator_writes_reads_back(status, parameter):
    value = -42_000 if parameter == "W" else -1.25
    line = format_charger(status, parameter, value)
    assert parse_charger(line) == ChargerReading(status, parameter, value)
    # All six as floats, W too: what the deployed drivers read (wire-facts).
    assert line.startswith(f"S:S#{status.value},{parameter}:F#")


def test_the_checksum_written_is_crc16_ccitt_false_of_the_text_before_it():
    assert crc16_ccitt_false(b"123456789") == 0x29B1  # the algorithm's check value
    line = format_charger(ChargeStatus.INIT, "D", 0.0)
    text, crc = line.split(" U#")
    assert int(crc, 16) == crc16_ccitt_false(text.encode("ascii"))


@pytest.mark.parametrize(
    "line",
    [
        "",
        "S:S#4",
        "S:S#9,B:F#cdccc841 U#c931",  # no such status
        "S:S#x,B:F#cdccc841 U#c931",
        "S:S#4,Q:F#cdccc841 U#c931",  # no such parameter
        "S:S#4,B:F*cdccc841 U#c931",  # the ordinary encoding, not the charger's
        "S:S#4,B:F#cdccc84 U#c931",  # seven hex digits
        "S:S#4,B:F#cdccc841",  # no checksum
        "S:S#4,B:F#cdccc841 U#c93",
        "S:S#4,B:F#0000807f U#c931",  # infinity
        "S:S#4,B:F#0000c07f U#c931",  # NaN
        "S:S#4,B:F#cdccc841 U#c931 S:S#4,B:F#cdccc841 U#c931",
        "cang:F*00000000,cdis:F*00000000",
        "S:S#4,B:F#cdccc841" + " " * 100 + "U#c931",
    ],
)
def test_garbage_is_a_protocol_error(line):
    with pytest.raises(ProtocolError):
        parse_charger(line)


@given(st.text(max_size=80))
def test_any_text_is_read_or_refused_with_a_protocol_error(text):
    try:
        reading = parse_charger(text)
    except ProtocolError:
        return
    assert reading.parameter in PARAMETERS


@given(
    st.binary(min_size=4, max_size=4),
    st.sampled_from(PARAMETERS),
    st.sampled_from("FI"),
    st.integers(0, 9),
)
def test_any_well_formed_line_is_read_or_refused_with_a_protocol_error(raw, parameter, kind, digit):
    line = f"S:S#{digit},{parameter}:{kind}#{raw.hex()} U#abcd"
    try:
        reading = parse_charger(line)
    except ProtocolError:
        assert digit > 4 or kind == "F"
        return
    expected = struct.unpack("<f" if kind == "F" else "<i", raw)[0]
    assert reading.value == expected


def test_a_charger_reply_passes_the_reply_parser_with_no_value():
    line = format_charger(ChargeStatus.NOT_DOCKED, "B", 24.0)
    reply = parse_reply([line])
    assert reply.lines == (line,)
    assert reply.value is None


def test_a_garbled_charger_reply_is_a_protocol_error_in_the_reply_parser():
    with pytest.raises(ProtocolError):
        parse_reply(["S:S#4,B:F#zz U#c931"])
