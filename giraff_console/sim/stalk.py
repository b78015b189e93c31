"""The head's height stalk on later boards: `h`, 0 to 1000 (wire-facts "Later firmware").

The range maps linearly to a head height of 1.16 m to 1.41 m. How fast the real stalk
moves is not known; here it takes four seconds from one end to the other (assumption),
so that a console sees it move rather than jump.
"""

from __future__ import annotations

STALK_RANGE = (0, 1000)
# Units per second: full travel in four seconds (assumption).
STALK_SPEED = 250.0


class Stalk:
    """The stalk's position over time: moves at a fixed speed towards its target."""

    def __init__(self, now: float, position: float = 0.0) -> None:
        self._from = position
        self._target = position
        self._since = now

    def position(self, now: float) -> float:
        travel = STALK_SPEED * max(0.0, now - self._since)
        if self._target >= self._from:
            return min(self._from + travel, self._target)
        return max(self._from - travel, self._target)

    def reading(self, now: float) -> int:
        """What `get h` answers: the position as a whole number."""
        return round(self.position(now))

    def move_to(self, target: float, now: float) -> None:
        """Start moving towards `target` (already checked to be in range)."""
        self._from = self.position(now)
        self._target = float(target)
        self._since = now

    def halt(self, now: float) -> None:
        """Stop where it is, as it does when the board loses power."""
        self.move_to(self.position(now), now)
