"""The bytes under the driver clients (clients.py): a raw serial port held as a file
descriptor, as a C driver holds it, and the board's text formats read from wire-facts.

Nothing here comes from the console's own code: the clients must be as independent of
it as the deployed drivers are, so that they test the wire and not our reading of it.
Every read has a deadline.
"""

from __future__ import annotations

import os
import select
import struct
import termios
import time
import tty

# Commands end with CR only; every exchange ends with this prompt (wire-facts "Serial line").
COMMAND_END = b"\r"
PROMPT = b"OK >\r\n"
# A `get` of one value: `F*aabbccdd\r\nOK >\r\n` (wire-facts "Replies").
SINGLE_VALUE_CHARS = 18


class ReplyTimeout(Exception):
    """No prompt within the deadline: a driver that waited for ever is a known failure
    (wire-facts "Known failures")."""


class RawPort:
    """A serial port as a file descriptor: raw, 115200 8N1, no flow control.

    Bytes read past a prompt stay in the buffer for the next read: a late reply is read
    as the next command's, as it would be by a driver reading the port (wire-facts
    "What the deployed drivers do", Pacing).
    """

    def __init__(self, fd: int, owns: bool = False) -> None:
        self.fd = fd
        self._owns = owns
        self._buffer = bytearray()

    @classmethod
    def open(cls, path: str) -> RawPort:
        """Open `path` and set it up as the drivers do: 115200 baud, 8N1, raw.

        The drivers also lower and raise DTR/RTS with ioctls, which a pseudo-terminal
        refuses (wire-facts "Opening the port"); on a pty, opening the port is what powers
        the simulated board, so these clients leave the modem lines alone.
        """
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(fd)
            attributes = termios.tcgetattr(fd)
            attributes[2] = (attributes[2] & ~(termios.PARENB | termios.CSTOPB | termios.CSIZE)) | (
                termios.CS8 | termios.CLOCAL | termios.CREAD
            )
            attributes[4] = attributes[5] = termios.B115200
            termios.tcsetattr(fd, termios.TCSANOW, attributes)
        except BaseException:
            os.close(fd)
            raise
        return cls(fd, owns=True)

    def close(self) -> None:
        if self._owns:
            os.close(self.fd)
            self._owns = False

    def write(self, data: bytes, timeout: float = 1.0) -> None:
        deadline = time.monotonic() + timeout
        view = memoryview(data)
        while view:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise ReplyTimeout(f"could not write {bytes(view)!r} within {timeout} s")
            if not select.select([], [self.fd], [], remaining)[1]:
                continue
            try:
                view = view[os.write(self.fd, view) :]
            except BlockingIOError:
                continue

    def _fill(self, deadline: float) -> bool:
        """Read what has arrived, waiting until `deadline` for something; True if any came."""
        remaining = deadline - time.monotonic()
        if remaining < 0 or not select.select([self.fd], [], [], max(0.0, remaining))[0]:
            return False
        try:
            chunk = os.read(self.fd, 4096)
        except (BlockingIOError, InterruptedError):
            return False
        self._buffer += chunk
        return bool(chunk)

    def reply_begun(self, timeout: float) -> bool:
        """Whether the first byte of a reply is here, or arrives within `timeout`."""
        deadline = time.monotonic() + timeout
        while not self._buffer:
            if time.monotonic() >= deadline:
                return False
            self._fill(deadline)
        return True

    def read_to_prompt(self, timeout: float) -> bytes:
        """Everything up to and including the next prompt; ReplyTimeout after `timeout`."""
        deadline = time.monotonic() + timeout
        while (end := self._buffer.find(PROMPT)) < 0:
            if time.monotonic() >= deadline:
                raise ReplyTimeout(f"no prompt within {timeout} s after {bytes(self._buffer)!r}")
            self._fill(deadline)
        end += len(PROMPT)
        reply = bytes(self._buffer[:end])
        del self._buffer[:end]
        return reply

    def discard_input(self) -> None:
        """Drop whatever has arrived and not been read."""
        while self._fill(time.monotonic()):
            pass
        self._buffer.clear()


def reply_lines(reply: bytes) -> list[str]:
    """The lines of a reply before its prompt, without their line ends."""
    text = reply[: -len(PROMPT)].decode("ascii", "replace")
    return [line for line in text.replace("\r", "\n").split("\n") if line.strip()]


def is_error(line: str) -> bool:
    """The board's error lines (wire-facts "Replies"): `Unknown name: x`, `ERROR: ...`,
    `Error: ...`."""
    return line.startswith(("Unknown name", "ERROR", "Error"))


def decode_value(text: str) -> float:
    """`F*`/`I*` and 8 hex digits, least significant byte first (wire-facts "Replies")."""
    kind, digits = text[:2], text[2:10]
    raw = bytes.fromhex(digits)
    if kind == "F*":
        return struct.unpack("<f", raw)[0]
    if kind == "I*":
        return float(struct.unpack("<i", raw)[0])
    raise ValueError(f"not a value: {text!r}")


def decode_list(line: str) -> dict[str, float]:
    """`name:value,name:value,...`, a trailing comma or not (wire-facts "Replies")."""
    fields = {}
    for item in filter(None, line.strip().split(",")):
        name, value = item.split(":", 1)
        fields[name] = decode_value(value)
    return fields


def charger_watt_seconds(line: str) -> float | None:
    """`W` from a `charger_data` line, `S:S#<status>,W:F#<hex> U#<crc>`, read only as a
    float, as both deployed drivers do (wire-facts "What the deployed drivers do",
    Battery); None for any other parameter, or for `W` in any other encoding."""
    marker = ",W:F#"
    at = line.find(marker)
    if not line.startswith("S:S#") or at < 0:
        return None
    digits = line[at + len(marker) : at + len(marker) + 8]
    try:
        return struct.unpack("<f", bytes.fromhex(digits))[0]
    except ValueError:
        return None
