"""The Slamtec RPLIDAR (A1/A2) serial protocol: pure functions, no I/O.

From Slamtec's protocol document (the A1/A2 "interface protocol and application notes"):

- A request is `A5 cmd`, or `A5 cmd size payload checksum` where the checksum is the
  XOR of every byte before it.
- A response starts with a 7-byte descriptor: `A5 5A`, then a 30-bit length and a
  2-bit send mode in four little-endian bytes, then a data type. Mode 0 is a single
  response, mode 1 a stream of `length`-byte records that lasts until STOP.
- A normal scan's record is 5 bytes: quality (6 bits) with the start flag S and its
  inverse !S; the angle in 1/64 degree (15 bits) after a check bit C that is always 1;
  the distance in 1/4 millimetre (16 bits). A distance of 0 is a failed measurement.

The sensor's angles grow clockwise seen from above (the protocol document's figure),
0 at the sensor's front.

The simulator encodes with these (sim/lidar.py); the console reads through the
adafruit-circuitpython-rplidar package (lidar/device.py) and the tests decode with
`decode_samples` to check both sides agree.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

import numpy as np

SYNC = 0xA5
SYNC_REPLY = 0x5A
SAMPLE_LEN = 5
# The largest payload a request may carry: its size is one byte.
MAX_PAYLOAD = 255


class Command(enum.IntEnum):
    STOP = 0x25
    RESET = 0x40
    SCAN = 0x20
    FORCE_SCAN = 0x21
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    SET_MOTOR_PWM = 0xF0  # A2 and later; an A1's motor follows DTR instead


class ReplyType(enum.IntEnum):
    """A descriptor's data type."""

    SCAN = 0x81
    INFO = 0x04
    HEALTH = 0x06


class SendMode(enum.IntEnum):
    SINGLE = 0
    MULTIPLE = 1


class Health(enum.IntEnum):
    """GET_HEALTH's status byte. ERROR is the protection stop: the sensor will not scan
    until it is reset."""

    GOOD = 0
    WARNING = 1
    ERROR = 2


INFO_LEN = 20
HEALTH_LEN = 3
# Commands that carry a payload (the protocol sets bit 7 of those): the rest are two bytes.
PAYLOAD_FLAG = 0x80


@dataclass(frozen=True)
class Request:
    command: int
    payload: bytes = b""


def request(command: int, payload: bytes | None = None) -> bytes:
    """One request on the wire; with a payload, its size and checksum."""
    if payload is None:
        return bytes((SYNC, command))
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"a payload is at most {MAX_PAYLOAD} bytes")
    body = bytes((SYNC, command, len(payload))) + payload
    return body + bytes((_xor(body),))


def parse_requests(buffer: bytearray) -> list[Request]:
    """The whole requests at the front of `buffer`, taken out of it. Bytes before a sync
    byte are dropped (line noise); a payload with a wrong checksum is dropped, as the
    sensor drops it. A request cut short stays in the buffer for the next bytes."""
    found = []
    while buffer:
        start = buffer.find(SYNC)
        if start < 0:
            buffer.clear()
            break
        del buffer[:start]
        if len(buffer) < 2:
            break
        command = buffer[1]
        if not command & PAYLOAD_FLAG:
            found.append(Request(command))
            del buffer[:2]
            continue
        if len(buffer) < 3 or len(buffer) < 4 + buffer[2]:
            break
        size = buffer[2]
        whole = bytes(buffer[: 4 + size])
        del buffer[: 4 + size]
        if _xor(whole[:-1]) == whole[-1]:
            found.append(Request(command, whole[3:-1]))
    return found


def descriptor(length: int, mode: SendMode, kind: ReplyType) -> bytes:
    """A response descriptor: `A5 5A`, the 30-bit length with the 2-bit mode above it,
    and the data type."""
    if not 0 <= length < 1 << 30:
        raise ValueError("a response length has 30 bits")
    return bytes((SYNC, SYNC_REPLY)) + struct.pack("<I", length | mode << 30) + bytes((kind,))


def info_reply(model: int, firmware: tuple[int, int], hardware: int, serial: bytes) -> bytes:
    """GET_INFO's answer: descriptor, model, firmware minor then major, hardware, and a
    16-byte serial number."""
    if len(serial) != 16:
        raise ValueError("a serial number is 16 bytes")
    major, minor = firmware
    body = bytes((model, minor, major, hardware)) + serial
    return descriptor(INFO_LEN, SendMode.SINGLE, ReplyType.INFO) + body


def health_reply(status: Health, error_code: int = 0) -> bytes:
    """GET_HEALTH's answer: descriptor, status, and a 16-bit error code."""
    body = bytes((status,)) + struct.pack("<H", error_code)
    return descriptor(HEALTH_LEN, SendMode.SINGLE, ReplyType.HEALTH) + body


def scan_descriptor() -> bytes:
    """SCAN's (and FORCE_SCAN's) descriptor: a stream of 5-byte samples."""
    return descriptor(SAMPLE_LEN, SendMode.MULTIPLE, ReplyType.SCAN)


def encode_samples(angle_deg: np.ndarray, distance_mm: np.ndarray, quality: np.ndarray,
                   start: np.ndarray) -> bytes:  # fmt: skip
    """Normal-scan samples, all at once: angles in [0, 360) degrees clockwise, distances
    in millimetres (0: no return), qualities 0..63, start flags (the first sample of a
    revolution)."""
    angle_q6 = np.round(np.asarray(angle_deg) * 64).astype(np.int64) % (360 * 64)
    distance_q2 = np.clip(np.round(np.asarray(distance_mm) * 4), 0, 0xFFFF).astype(np.int64)
    flags = np.asarray(start, dtype=np.int64)
    first = (np.clip(np.asarray(quality), 0, 63).astype(np.int64) << 2) | ((1 - flags) << 1) | flags
    out = np.empty((len(angle_q6), SAMPLE_LEN), dtype=np.uint8)
    out[:, 0] = first
    out[:, 1] = ((angle_q6 & 0x7F) << 1) | 1  # the check bit C
    out[:, 2] = angle_q6 >> 7
    out[:, 3] = distance_q2 & 0xFF
    out[:, 4] = distance_q2 >> 8
    return out.tobytes()


@dataclass(frozen=True)
class Samples:
    """Decoded normal-scan samples, as arrays."""

    start: np.ndarray
    quality: np.ndarray
    angle_deg: np.ndarray
    distance_mm: np.ndarray


def decode_samples(data: bytes) -> Samples:
    """Normal-scan samples from whole 5-byte records; ValueError if a record's S/!S or
    check bit is wrong (the stream is out of step)."""
    if len(data) % SAMPLE_LEN:
        raise ValueError("samples are 5 bytes each")
    raw = np.frombuffer(data, dtype=np.uint8).reshape(-1, SAMPLE_LEN).astype(np.int64)
    start = raw[:, 0] & 1
    if np.any(start == (raw[:, 0] >> 1) & 1) or np.any(raw[:, 1] & 1 == 0):
        raise ValueError("a sample's flags are wrong: the stream is out of step")
    return Samples(
        start.astype(bool), raw[:, 0] >> 2, ((raw[:, 1] >> 1) | (raw[:, 2] << 7)) / 64.0,
        (raw[:, 3] | (raw[:, 4] << 8)) / 4.0,
    )  # fmt: skip


def _xor(data: bytes) -> int:
    checksum = 0
    for byte in data:
        checksum ^= byte
    return checksum
