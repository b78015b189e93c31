"""Encoding commands and decoding values (Appendix A.3-A.4, wire-facts "Replies").

Commands are plain ASCII ended by CR. Values come back hex-encoded: `F*aabbccdd` is an
IEEE-754 single and `I*aabbccdd` a 32-bit two's-complement integer, both with the least
significant byte first. Plain ASCII numbers are accepted too, as the original's
FormatField did.
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass
from decimal import Decimal
from typing import Literal

from giraff_console.protocol.errors import CommandError, ProtocolError
from giraff_console.protocol.framing import COMMAND_END

Number = float | int

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_HEX_VALUE = re.compile(r"([FI])\*([0-9A-Fa-f]{8})\Z")
_ASCII_INT = re.compile(r"[+-]?\d+\Z", re.ASCII)
_ASCII_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z", re.ASCII)
# No value the board sends is anywhere near this long; longer text is noise.
_MAX_VALUE_CHARS = 40
FLOAT32_MAX = 3.4028234663852886e38
# Values go out with at most this many decimals, and below this magnitude: the board's
# line buffer is small and nothing on the robot needs more (see format_number).
DECIMALS = 9
MAX_MAGNITUDE = 1e9

CommandKind = Literal["set", "get", "command"]


def format_number(value: Number) -> str:
    """A number as short plain decimal text: no exponent, no NaN or infinity.

    The board's parser reads plain decimals; `1e-05` must go out as `0.00001`. Values
    are rounded to nine decimals and must stay below 1e9 in magnitude, so that no
    command outgrows the board's line buffer.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise CommandError(f"not a number: {value!r}")
    if not math.isfinite(value):
        raise CommandError(f"refusing to send a non-finite value: {value!r}")
    if abs(value) >= MAX_MAGNITUDE:
        raise CommandError(f"refusing to send a value this large: {value!r}")
    if isinstance(value, int):
        return str(value)
    # repr() is the shortest text that reads back as the same float.
    text = format(round(Decimal(repr(value)), DECIMALS), "f")
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def parse_number(text: str) -> Number:
    """A plain ASCII number as an int or a float; anything else is a CommandError."""
    text = text.strip()
    if len(text) > _MAX_VALUE_CHARS:
        raise CommandError(f"number too long: {text[:20]!r}...")
    if _ASCII_INT.match(text):
        return int(text)
    if _ASCII_FLOAT.match(text):
        value = float(text)
        if math.isfinite(value):
            return value
    raise CommandError(f"not a number: {text!r}")


def check_name(name: str) -> str:
    """A parameter or command name, checked so that it cannot smuggle in a second command."""
    if not _NAME.match(name):
        raise CommandError(f"not a valid parameter or command name: {name!r}")
    return name


@dataclass(frozen=True)
class Command:
    """One command for the board: `set NAME VALUE`, `get NAME` or a bare `NAME`."""

    kind: CommandKind
    name: str
    value: Number | None = None

    def __post_init__(self) -> None:
        check_name(self.name)
        if (self.kind == "set") != (self.value is not None):
            raise CommandError("`set` needs a value and only `set` takes one")

    @property
    def text(self) -> str:
        """The command as typed, without the terminator."""
        if self.kind == "set":
            assert self.value is not None
            return f"set {self.name} {format_number(self.value)}"
        if self.kind == "get":
            return f"get {self.name}"
        return self.name

    @property
    def wire(self) -> bytes:
        """The bytes that go on the wire, CR included."""
        return self.text.encode("ascii") + COMMAND_END

    def __str__(self) -> str:
        return self.text


def encode_set(name: str, value: Number) -> bytes:
    """`set NAME VALUE\\r`."""
    return Command("set", name, value).wire


def encode_get(name: str) -> bytes:
    """`get NAME\\r`."""
    return Command("get", name).wire


def encode_command(name: str) -> bytes:
    """A bare command such as `home\\r`."""
    return Command("command", name).wire


def parse_command(text: str) -> Command:
    """A command typed by a person (`set v 0.3`, `get bulk_data`, `home`).

    Anything that is not exactly one well-formed command is refused, so that typed input
    containing CR or LF can never send a second command. Names are read without regard
    to case and come back in lower case, the board's own spelling (A.4): `set P 5` is
    `set p 5`, and it is that command that is checked and sent.
    """
    if any(ch in text for ch in "\r\n") or not text.isascii() or not text.isprintable():
        raise CommandError("a command must be one line of printable ASCII")
    words = text.lower().split()
    if not words:
        raise CommandError("empty command")
    op = words[0]
    if op == "set":
        if len(words) != 3:
            raise CommandError("usage: set NAME VALUE")
        return Command("set", words[1], parse_number(words[2]))
    if op == "get":
        if len(words) != 2:
            raise CommandError("usage: get NAME")
        return Command("get", words[1])
    if len(words) != 1:
        raise CommandError(f"unexpected arguments after {op!r}")
    return Command("command", op)


def encode_float(value: float) -> str:
    """A value in the board's float encoding, `F*` and little-endian hex.

    Values beyond the float32 range become infinities, as they would on the board.
    """
    if math.isfinite(value) and abs(value) > FLOAT32_MAX:
        value = math.copysign(math.inf, value)
    return "F*" + struct.pack("<f", value).hex()


def encode_int(value: int) -> str:
    """A value in the board's integer encoding, `I*` and little-endian hex."""
    return "I*" + struct.pack("<i", value).hex()


def decode_value(text: str) -> Number:
    """One value from a reply: `F*aabbccdd`, `I*aabbccdd` (either hex case) or ASCII."""
    text = text.strip()
    if len(text) > _MAX_VALUE_CHARS:
        raise ProtocolError(f"garbled value: {text[:20]!r}...")
    match = _HEX_VALUE.match(text)
    if match:
        kind, digits = match.groups()
        raw = bytes.fromhex(digits)
        if kind == "F":
            return struct.unpack("<f", raw)[0]
        return struct.unpack("<i", raw)[0]
    if _ASCII_INT.match(text):
        return int(text)
    if _ASCII_FLOAT.match(text):
        return float(text)
    raise ProtocolError(f"garbled value: {text[:40]!r}")
