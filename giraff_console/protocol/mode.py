"""The `mode` bitmask (Appendix A.4.8)."""

from __future__ import annotations

import enum


class ModeBit(enum.IntFlag):
    """Bits of `set mode` / `get mode`.

    ABSOLUTE and BUFFERED are written by the host; ESTOP and MOVING are read-only
    status bits that only the board sets.
    """

    ABSOLUTE = 1
    BUFFERED = 4
    ESTOP = 8
    MOVING = 128


# Only the low four bits can be written (the thesis's simulator masks with 0xf).
WRITABLE_MODE_MASK = 0x0F
