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

# Giraff-X's `set twm vg cdp vgr v p 0` sets a whole curved move in one command; it was
# added because the same parameters sent as several `set`s made the motors jerk and
# pause (wire-facts, "Later firmware"). What the closing 0 means is not documented:
# drivers always send 0 there.
TWM = "twm"
TWM_SETTINGS = ("vg", "cdp", "vgr", "v", "p")
# How many values a `set` of each name takes; every other `set` takes one.
SET_VALUES = {TWM: len(TWM_SETTINGS) + 1}
SetValue = Number | tuple[Number, ...]


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


def values_taken(name: str) -> int:
    """How many values `set NAME` takes: six for a twm, one for anything else."""
    return SET_VALUES.get(name, 1)


def names_set(name: str) -> tuple[str, ...]:
    """The settings `set NAME` changes: the five a twm carries, else NAME itself."""
    return TWM_SETTINGS if name == TWM else (name,)


def settings_of(name: str, text: str) -> dict[str, str]:
    """What the board holds after it took `set NAME TEXT`, each setting as on the wire:
    a twm sets the five settings it carries (its closing 0 is none of them)."""
    words = text.split()
    if len(words) != values_taken(name):
        raise CommandError(f"set {name} takes {values_taken(name)} values, not {text!r}")
    return dict(zip(names_set(name), words, strict=False))


@dataclass(frozen=True)
class Command:
    """One command for the board: `set NAME VALUE`, `get NAME` or a bare `NAME`.

    A `set` takes one value, except a twm, which takes a tuple of six (TWM_SETTINGS and
    the closing 0).
    """

    kind: CommandKind
    name: str
    value: SetValue | None = None

    def __post_init__(self) -> None:
        check_name(self.name)
        if (self.kind == "set") != (self.value is not None):
            raise CommandError("`set` needs a value and only `set` takes one")
        wanted = values_taken(self.name)
        several = isinstance(self.value, tuple)
        if self.kind == "set" and (several != (wanted > 1) or len(self.values) != wanted):
            raise CommandError(f"set {self.name} takes {'a tuple of ' if wanted > 1 else ''}"
                               f"{wanted} value{'s' if wanted > 1 else ''}")  # fmt: skip

    @property
    def values(self) -> tuple[Number, ...]:
        """The values of a `set`, one or more; none for anything else."""
        if self.value is None:
            return ()
        return self.value if isinstance(self.value, tuple) else (self.value,)

    @property
    def settings(self) -> dict[str, str]:
        """What the board holds once it took this `set`, each setting as on the wire
        (settings_of); nothing for a `get` or a bare command."""
        if self.kind != "set":
            return {}
        return settings_of(self.name, self.text.split(None, 2)[2])

    @property
    def text(self) -> str:
        """The command as typed, without the terminator."""
        if self.kind == "set":
            return f"set {self.name} " + " ".join(format_number(v) for v in self.values)
        if self.kind == "get":
            return f"get {self.name}"
        return self.name

    @property
    def wire(self) -> bytes:
        """The bytes that go on the wire, CR included."""
        return self.text.encode("ascii") + COMMAND_END

    def __str__(self) -> str:
        return self.text


def encode_set(name: str, value: SetValue) -> bytes:
    """`set NAME VALUE\\r`."""
    return Command("set", name, value).wire


def encode_get(name: str) -> bytes:
    """`get NAME\\r`."""
    return Command("get", name).wire


def encode_command(name: str) -> bytes:
    """A bare command such as `home\\r`."""
    return Command("command", name).wire


def parse_command(text: str) -> Command:
    """A command typed by a person (`set v 0.3`, `get bulk_data`, `home`, and on
    Giraff-X `set twm 0.2 0.1 1 0.3 0.2 0`).

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
        if len(words) < 3:
            raise CommandError("usage: set NAME VALUE")
        name, values = check_name(words[1]), words[2:]
        if len(values) != values_taken(name):
            if name == TWM:
                raise CommandError(f"usage: set twm {' '.join(TWM_SETTINGS)} 0")
            raise CommandError("usage: set NAME VALUE")
        numbers = tuple(parse_number(word) for word in values)
        return Command("set", name, numbers if len(numbers) > 1 else numbers[0])
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
