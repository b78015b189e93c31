"""The synthetic camera's socket, as the simulator serves it: a frame asked for, a frame
answered (pure, no I/O).

`giraff-console sim --camera PATH` serves the synthetic camera on a Unix socket, and the
console's `SocketCamera` reads it (camera/socket_wire.py is its side of this format,
kept alike constant for constant: the simulator imports nothing of the console, nor the
console's camera package anything of the simulator).

A client asks with a request of `REQUEST.size` (8) bytes: the magic `GCF1`, then the
width and height in pixels, unsigned 16-bit little-endian. Each side must be
`MIN_SIDE` to `MAX_SIDE`; anything else is refused before a pixel is allocated.

The server answers with a header of `REPLY.size` (14) bytes: the magic, the status
(`FRAME` or `REFUSED`, 16 bits), width and height, and the length of the body that
follows (32 bits), all little-endian. A frame's body is the picture as OpenCV holds it:
`height` rows of `width` BGR pixels, a byte a channel, so exactly width x height x 3
bytes. A refusal's body is at most `MAX_REASON` bytes of UTF-8 saying why; the server
then closes the connection. A client asks for its next frame once it has read the last.
"""

from __future__ import annotations

import struct
from enum import IntEnum

MAGIC = b"GCF1"
REQUEST = struct.Struct("<4sHH")
REPLY = struct.Struct("<4sHHHI")
# 16 px is about the least a picture could show a marker in; 4096 px a side (48 MiB a
# frame) is more than any camera the console drives delivers (its largest is 1600x1200).
MIN_SIDE = 16
MAX_SIDE = 4096
MAX_REASON = 200
CHANNELS = 3


class ReplyStatus(IntEnum):
    FRAME = 0
    REFUSED = 1


class FrameRequestError(ValueError):
    """A request that is not this format, or asks for a size outside its limits."""


def decode_request(data: bytes) -> tuple[int, int]:
    """The (width, height) asked for; FrameRequestError, saying why, for anything else."""
    magic, width, height = REQUEST.unpack(data)
    if magic != MAGIC:
        raise FrameRequestError(f"not a frame request (it starts {magic!r}, not {MAGIC!r})")
    if not (MIN_SIDE <= width <= MAX_SIDE and MIN_SIDE <= height <= MAX_SIDE):
        raise FrameRequestError(
            f"a frame of {width}x{height} px: each side must be {MIN_SIDE} to {MAX_SIDE} px"
        )
    return width, height


def encode_frame_header(width: int, height: int) -> bytes:
    """The header of a frame of a size `decode_request` took."""
    return REPLY.pack(MAGIC, ReplyStatus.FRAME, width, height, width * height * CHANNELS)


def encode_refusal(reason: str) -> bytes:
    """The whole refusal, header and reason, the reason cut to MAX_REASON bytes."""
    text = reason.encode("utf-8")[:MAX_REASON].decode("utf-8", "ignore").encode("utf-8")
    return REPLY.pack(MAGIC, ReplyStatus.REFUSED, 0, 0, len(text)) + text
