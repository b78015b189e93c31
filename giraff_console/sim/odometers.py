"""What the board's firmware makes of the wheels' travel: `imdl`/`imdr` and `enc0`/`enc1`.

The thesis's board reports `imdl`/`imdr` as the wheels' travel since power-up. Later
boards report the travel since the previous `get bulk_data`, resetting them on every
read, and count each wheel on a 16-bit encoder (wire-facts, "Later firmware").
"""

from __future__ import annotations

import math

# Encoder counts per metre of that wheel's travel, and where the counter wraps
# (wire-facts "Wheel encoders").
ENCODER_COUNTS_PER_M = 2002.0594
ENCODER_MODULUS = 65536


class WheelCounters:
    """The left (0) and right (1) wheels' counters, from their true travel in metres."""

    def __init__(self, incremental: bool) -> None:
        self.incremental = incremental
        # Each wheel's travel at the previous read.
        self._last = (0.0, 0.0)
        self._encoder_base = [0, 0]

    def odometers(self, left: float, right: float) -> tuple[float, float]:
        """`imdl`, `imdr` for wheels that have travelled `left` and `right` metres since
        power-up; on incremental firmware this read resets them.

        The board keeps the exact travel and sends each increment as a float32, so a
        read at rest gives exactly 0 and the increments add up to the true travel to
        within a float32 rounding per read (a micrometre over a long run).
        """
        if not self.incremental:
            return left, right
        steps = (left - self._last[0], right - self._last[1])
        self._last = (left, right)
        return steps

    def encoder(self, wheel: int, travel: float) -> int:
        """The counter of a wheel that has travelled `travel` metres since power-up.

        Whole counts from the exact travel, so the fraction of a count is never lost.
        """
        counts = math.floor(travel * ENCODER_COUNTS_PER_M)
        return (counts + self._encoder_base[wheel]) % ENCODER_MODULUS

    def set_encoder(self, wheel: int, travel: float, count: int) -> None:
        """`set encN count`: the counter reads `count` now and counts on from there."""
        self._encoder_base[wheel] = count - math.floor(travel * ENCODER_COUNTS_PER_M)
