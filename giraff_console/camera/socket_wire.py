"""The console's side of the camera socket's format (`--camera unix:PATH`): a frame
asked for, a frame answered (pure, no I/O).

The format is sim/camera_wire.py's, which describes it; the constants are kept alike
there and here, as the two `CameraIntrinsics` are, since the camera package imports
nothing of the simulator (tests/camera/test_socket_camera.py checks that they agree).
A reply is checked before anything is allocated for its body.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

MAGIC = b"GCF1"
REQUEST = struct.Struct("<4sHH")
REPLY = struct.Struct("<4sHHHI")
MIN_SIDE = 16
MAX_SIDE = 4096
MAX_REASON = 200
CHANNELS = 3


class ReplyStatus(IntEnum):
    FRAME = 0
    REFUSED = 1


class CameraWireError(ValueError):
    """Bytes that are not this format, or a size outside its limits; says which."""


@dataclass(frozen=True)
class Reply:
    """A reply's header: what follows it, and how long it is."""

    status: ReplyStatus
    width: int
    height: int
    length: int


def check_size(width: int, height: int) -> None:
    """CameraWireError unless both sides are within MIN_SIDE..MAX_SIDE pixels."""
    if not (MIN_SIDE <= width <= MAX_SIDE and MIN_SIDE <= height <= MAX_SIDE):
        raise CameraWireError(
            f"a frame of {width}x{height} px: each side must be {MIN_SIDE} to {MAX_SIDE} px"
        )


def encode_request(width: int, height: int) -> bytes:
    check_size(width, height)
    return REQUEST.pack(MAGIC, width, height)


def decode_reply(data: bytes) -> Reply:
    """A reply's header: CameraWireError for a wrong magic or status, a frame whose size
    is out of bounds or whose length is not its size's, or a reason too long."""
    magic, status, width, height, length = REPLY.unpack(data)
    if magic != MAGIC:
        raise CameraWireError(f"not a camera reply (it starts {magic!r}, not {MAGIC!r})")
    if status == ReplyStatus.REFUSED:
        if length > MAX_REASON:
            raise CameraWireError(f"a refusal of {length} bytes; at most {MAX_REASON}")
        return Reply(ReplyStatus.REFUSED, 0, 0, length)
    if status != ReplyStatus.FRAME:
        raise CameraWireError(f"an unknown reply status {status}")
    check_size(width, height)
    if length != width * height * CHANNELS:
        raise CameraWireError(f"a {width}x{height} frame of {length} bytes, not "
                              f"{width * height * CHANNELS}")  # fmt: skip
    return Reply(ReplyStatus.FRAME, width, height, length)
