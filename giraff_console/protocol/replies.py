"""Decoding what the board says between a command and its `OK >` prompt.

A reply is zero or more lines: a single value, a `name:value,...` list (real boards end
it with a comma), or an error line. A `set` may be answered with the new value, with
nothing, or with `New Value: ...` on one firmware (wire-facts "Replies"). Later boards
answer `get charger_data` in an encoding of their own (protocol/charger.py): such a line
is checked here and passed through raw, with no value; `BoardLink.charger` reads it.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from giraff_console.protocol.charger import is_charger_line, parse_charger
from giraff_console.protocol.codec import Number, decode_value
from giraff_console.protocol.errors import (
    ArgumentError,
    BoardError,
    BoardRebootedError,
    ProtocolError,
    QueueRolloverError,
    UnknownNameError,
)
from giraff_console.protocol.framing import CALIBRATION_LINE, is_banner

ReplyValue = Number | dict[str, Number] | None

_LIST_ITEM = re.compile(r"([A-Za-z_][A-Za-z0-9_]*):([^,:]*)\Z")
_UNKNOWN_NAME = re.compile(r"Unknown name:\s*(.*)\Z")
_NEW_VALUE = re.compile(r"New Value:\s*(.*)\Z", re.IGNORECASE)
_HEX_FIELD = re.compile(r"([FI])\*([0-9A-Fa-f]{8})")


@dataclass(frozen=True)
class Reply:
    """A decoded reply: the raw lines and the value they carry, if any."""

    lines: tuple[str, ...]
    value: ReplyValue


def board_error(line: str) -> BoardError | None:
    """The typed error for an error line, or None if the line is not one."""
    text = line.strip()
    match = _UNKNOWN_NAME.match(text)
    if match:
        return UnknownNameError(text, match.group(1).strip())
    if text.upper().startswith("ERROR"):
        if "rollover" in text.lower():
            return QueueRolloverError(text)
        if text.startswith("Error:"):
            return ArgumentError(text)
        return BoardError(text)
    return None


def decode_list(text: str) -> dict[str, Number]:
    """`name:value,name:value,` as an ordered dict; the trailing comma is optional."""
    items = text.strip().split(",")
    if items and items[-1] == "":
        items.pop()
    if not items:
        raise ProtocolError("empty list reply")
    values: dict[str, Number] = {}
    for item in items:
        match = _LIST_ITEM.match(item)
        if not match:
            raise ProtocolError(f"garbled list item: {item[:40]!r}")
        name, value = match.groups()
        values[name] = decode_value(value)
    return values


def decode_line(line: str) -> Number | dict[str, Number]:
    """The value carried by one reply line."""
    text = line.strip()
    labelled = _NEW_VALUE.match(text)
    if labelled:
        text = labelled.group(1)
    if ":" in text:
        return decode_list(text)
    return decode_value(text)


def parse_reply(lines: Iterable[str]) -> Reply:
    """Decode the lines that came before the prompt.

    Raises a `BoardError` subclass for an error line, `BoardRebootedError` if the board
    greeted again, and `ProtocolError` for anything garbled or unexpected.
    """
    kept = tuple(line.strip() for line in lines if line.strip())
    for line in kept:
        error = board_error(line)
        if error is not None:
            raise error
        if is_banner(line) or line == CALIBRATION_LINE:
            raise BoardRebootedError(f"the board restarted: {line[:60]!r}")
    if not kept:
        return Reply(kept, None)
    if len(kept) > 1:
        raise ProtocolError(f"expected one reply line, got {len(kept)}: {kept[0][:40]!r}...")
    if is_charger_line(kept[0]):
        # `S:S#4,B:F#...` is no list of values; a garbled one is a ProtocolError here,
        # so the exchange that carried it records the error.
        parse_charger(kept[0])
        return Reply(kept, None)
    return Reply(kept, decode_line(kept[0]))


def format_value(value: Number) -> str:
    """A value as the original console showed it: floats with five decimals (B.2)."""
    if isinstance(value, int):
        return str(value)
    return f"{value:.5f}"


def format_reply(line: str) -> str:
    """A reply line with every hex-encoded field decoded in place.

    This is the original's FormatReply (B.2): names, commas and anything that is not a
    hex value are copied verbatim, so a partly garbled line still reads sensibly.
    """

    def decode(match: re.Match[str]) -> str:
        return format_value(decode_value(match.group(0)))

    return _HEX_FIELD.sub(decode, line.strip())
