"""Board replies: whatever bytes come back before the prompt, parse_reply gives a value
or a GiraffError (ProtocolError, BoardError), never another exception (issue 12)."""

from __future__ import annotations

import contextlib
import random

from hypothesis import given

from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.framing import is_banner, is_prompt
from giraff_console.protocol.replies import format_reply, parse_reply
from tests.fuzz.inputs import FUZZ, TOKENS, cases, mutated, raw_bytes

# A bulk_data reply as a real board sends it (wire-facts "Replies"), then other kinds.
BULK = (
    b"cang:F*00000000,cdis:F*0000803f,gvr:F*0000807f,tilt_angle_from_home:F*cdcc4c3d,"
    b"imdl:F*00000000,imdr:F*00000000,cvg:F*00000000,mode:I*80000000,\r\n"
)
REPLIES = (
    BULK, b"F*9a99993e\r\n", b"I*e8030000\r\n", b"New Value: 0.3\r\n", b"\r\n",
    b"Unknown name: xyz\r\n", b"ERROR: Queue rollover\r\n", b"Error: bad value\r\n",
    b"# Giraf 1.1.112p, 2011-02-20\r\n", b"Ca>\r\n", b"0.30000\r\n", b"-12\r\n",
)  # fmt: skip


def reply_lines(data: bytes) -> list[str]:
    """The lines before the prompt, decoded as BoardLink._read_until_prompt does."""
    lines = []
    for raw in data.split(b"\n"):
        line = raw.decode("ascii", "replace").strip()
        if is_prompt(line):
            break
        if line:
            lines.append(line)
    return lines


def hex_value(rng: random.Random) -> bytes:
    """A list reply of hex values with random bits: NaN, infinities, denormals."""
    fields = [
        b"%s:%s*%08x" % (name, rng.choice((b"F", b"I", b"f", b"X")), rng.getrandbits(32))
        for name in rng.sample((b"cang", b"cdis", b"gvr", b"cvg", b"mode", b"imdl", b"9x"), 5)
    ]
    return b",".join(fields) + rng.choice((b",\r\n", b"\r\n", b""))


def mixed(rng: random.Random) -> bytes:
    parts = [rng.choice(REPLIES + TOKENS) for _ in range(rng.randint(1, 4))]
    return b"".join(parts)


def test_a_real_bulk_reply_decodes():
    value = parse_reply(reply_lines(BULK + b"OK >\r\n")).value
    assert isinstance(value, dict) and value["mode"] == 128


@FUZZ
@given(data=cases(raw_bytes, mutated(BULK), hex_value, mixed, mixed))
def test_any_bytes_give_a_reply_or_a_typed_error(data):
    lines = reply_lines(data)
    for line in lines:
        format_reply(line)  # what the transcript and the session log show
        is_banner(line)
    with contextlib.suppress(GiraffError):
        parse_reply(lines)
