"""Bytes that take as long as a 115200-baud line would take to carry them.

The thesis's simulator slept for the transmission time of each reply (B.2 SimulateLag).
Here each direction of the full-duplex line is a `PacedStream`: bytes are queued with
the time they become available at the far end, one byte time apart, and never faster
than the line can carry them.
"""

from __future__ import annotations

import math
from collections import deque

from giraff_console.protocol.framing import BYTE_TIME_S


class PacedStream:
    """One direction of a serial line; with `paced` False, bytes arrive at once."""

    def __init__(self, paced: bool) -> None:
        self.byte_time = BYTE_TIME_S if paced else 0.0
        self._chunks: deque[tuple[bytearray, float]] = deque()
        self._line_free_at = -math.inf

    def push(self, data: bytes, at: float) -> None:
        """Start sending `data` at time `at`, or when the line is next free."""
        if not data:
            return
        start = max(at, self._line_free_at)
        self._chunks.append((bytearray(data), start))
        self._line_free_at = start + len(data) * self.byte_time

    def _arrived(self, data: bytearray, start: float, now: float) -> int:
        if self.byte_time:
            return max(0, min(len(data), int((now - start) / self.byte_time + 1e-9)))
        return len(data) if now >= start else 0

    def available(self, now: float) -> int:
        """How many bytes have arrived by `now`."""
        total = 0
        for data, start in self._chunks:
            count = self._arrived(data, start, now)
            total += count
            if count < len(data):
                break
        return total

    def pop_due(self, now: float, limit: int | None = None) -> bytes:
        """The bytes that have fully arrived by `now` (at most `limit`)."""
        out = bytearray()
        while self._chunks and (limit is None or len(out) < limit):
            data, start = self._chunks[0]
            count = self._arrived(data, start, now)
            if limit is not None:
                count = min(count, limit - len(out))
            if count <= 0:
                break
            out += data[:count]
            del data[:count]
            if data:
                self._chunks[0] = (data, start + count * self.byte_time)
            else:
                self._chunks.popleft()
        return bytes(out)

    def due_time(self, through: bytes | None = None) -> float | None:
        """When the next byte arrives; with `through`, when the next such byte has arrived.

        Waiting for the end of a line instead of every byte keeps a real-time server
        from waking up 11520 times a second.
        """
        for data, start in self._chunks:
            index = 0 if through is None else data.find(through)
            if index >= 0:
                return start + (index + 1) * self.byte_time
        if self._chunks and through is not None:
            data, start = self._chunks[-1]
            return start + len(data) * self.byte_time
        return None

    def clear(self) -> None:
        """Drop everything still on the line; the line is free at once."""
        self._chunks.clear()
        self._line_free_at = -math.inf

    def __len__(self) -> int:
        return sum(len(data) for data, _ in self._chunks)
