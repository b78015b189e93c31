"""The battery charger's reply to `get charger_data` (wire-facts "Later firmware").

Later boards answer with one line in an encoding of their own:
`S:S#<status>,<P>:<F|I>#<8 hex> U#<4 hex>`. The status ends in a digit (0 fast
charging, 1 trickle, 2 error, 3 init, 4 not docked); each read carries one parameter,
in turn `B` battery V, `b` battery A, `t` battery degC, `D` dock V, `d` dock A and `W`
watt-seconds drawn (0 = full). The hex is little-endian, as in `F*`/`I*`. The last field
is a checksum whose algorithm on real boards is undocumented, so any four hex digits are
accepted; the simulator writes CRC-16/CCITT-FALSE of the text before ` U#`.
"""

from __future__ import annotations

import enum
import math
import re
import struct
from dataclasses import dataclass

from giraff_console.protocol.errors import ProtocolError

# The charger's parameters, in the order a board reports them, read after read.
PARAMETERS = ("B", "b", "t", "D", "d", "W")

# No charger line a board sends is anywhere near this long; longer text is noise.
_MAX_LINE_CHARS = 60
_CHARGER_LINE = re.compile(
    r"S:S#(?P<status>[0-9A-Za-z]{0,3}?\d),"
    r"(?P<parameter>[A-Za-z]):(?P<kind>[FI])#(?P<hex>[0-9A-Fa-f]{8})"
    r"\s+U#(?P<crc>[0-9A-Fa-f]{4}),?\Z",
    re.ASCII,
)


class ChargeStatus(enum.IntEnum):
    """The charger's state: the digit that ends the `S#` field."""

    FAST_CHARGING = 0
    TRICKLE_CHARGING = 1
    ERROR = 2
    INIT = 3
    NOT_DOCKED = 4


@dataclass(frozen=True)
class ChargerReading:
    """One `get charger_data` reply: the status and one parameter's value."""

    status: ChargeStatus
    parameter: str
    value: float


def is_charger_line(line: str) -> bool:
    """True for a line that looks like a charger reply (starts `S:S#`), garbled or not."""
    return line.strip().startswith("S:S#")


def parse_charger(line: str) -> ChargerReading:
    """The reading in one charger line; ProtocolError for anything else, never another error."""
    text = line.strip()
    if len(text) > _MAX_LINE_CHARS:
        raise ProtocolError(f"garbled charger line: {text[:30]!r}...")
    match = _CHARGER_LINE.match(text)
    if not match:
        raise ProtocolError(f"garbled charger line: {text[:60]!r}")
    digit = int(match.group("status")[-1])
    if digit not in ChargeStatus._value2member_map_:
        raise ProtocolError(f"unknown charger status {digit} in {text[:60]!r}")
    parameter = match.group("parameter")
    if parameter not in PARAMETERS:
        raise ProtocolError(f"unknown charger parameter {parameter!r} in {text[:60]!r}")
    raw = bytes.fromhex(match.group("hex"))
    if match.group("kind") == "F":
        value = float(struct.unpack("<f", raw)[0])
        if not math.isfinite(value):
            raise ProtocolError(f"charger value is not a number: {text[:60]!r}")
    else:
        value = float(struct.unpack("<i", raw)[0])
    return ChargerReading(ChargeStatus(digit), parameter, value)


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): what the simulator signs lines with."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def format_charger(status: ChargeStatus | int, parameter: str, value: float) -> str:
    """The charger line for one reading, as a later board writes it (no line end).

    Every parameter goes out as a float (`F#`), `W` included: both deployed drivers read
    `W` as `W:F#<hex>` and recognise nothing else (wire-facts "What the deployed drivers
    do", Battery), so that is what real boards send. `parse_charger` still reads `I#`,
    which the format allows (wire-facts "Battery": `<T>` is `F` or `I`).
    """
    code = ChargeStatus(status)
    if parameter not in PARAMETERS:
        raise ValueError(f"unknown charger parameter: {parameter!r}")
    field = "F#" + struct.pack("<f", value).hex()
    text = f"S:S#{int(code)},{parameter}:{field}"
    return f"{text} U#{crc16_ccitt_false(text.encode('ascii')):04x}"
