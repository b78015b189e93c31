"""The head's height stalk of later boards: `h`, 0 to 1000 (wire-facts "Later firmware").

The setting maps linearly to a head height of 1.16 m to 1.41 m. The board moves the
stalk to a set height at a finite speed and stops there; it never runs on by itself.
"""

from __future__ import annotations

STALK_LOW = 0
STALK_HIGH = 1000
LOWEST_HEAD_M = 1.16
HIGHEST_HEAD_M = 1.41
# One step of `stalk up` / `stalk down` and of the keys: 2.5 cm of head height.
STALK_STEP = 100


def head_height(stalk: float) -> float:
    """The head's height in metres for a stalk setting."""
    return LOWEST_HEAD_M + (HIGHEST_HEAD_M - LOWEST_HEAD_M) * stalk / STALK_HIGH


def stepped(stalk: int, steps: int) -> int:
    """The setting `steps` steps from `stalk`, kept within the stalk's range."""
    return min(STALK_HIGH, max(STALK_LOW, stalk + steps * STALK_STEP))
