"""The head's tilt motor and its homing sequence (A.4.10-A.4.12)."""

from __future__ import annotations

# The home (sleep) position, about 45 degrees off vertical; angles count from it.
HOME_TILT = 0.0872664  # the thesis simulator's default_tilt (B.2)
TILT_LIMITS = (0.087, 2.094)  # radians from home (wire-facts "Head")
# Tilting before homing has finished lands "usually at the wrong angle" (A.4.12).
UNHOMED_ERROR = 0.35


class HomingState:
    """Values of `tilt_homing_state` (A.4.11)."""

    NOT_STARTED = 0
    HOMING = 1
    FAILED = 2
    DONE = 3


class Head:
    """Tilt angle over time: moves at a fixed speed towards its target."""

    def __init__(self, homing_seconds: float, speed: float, now: float) -> None:
        self._homing_seconds = homing_seconds
        self._speed = speed
        self._state = HomingState.NOT_STARTED
        self._homing_done_at = 0.0
        self._from = HOME_TILT
        self._target = HOME_TILT
        self._since = now

    def home(self, now: float) -> None:
        """Start homing: the head tilts slowly back to its home position."""
        self._go(HOME_TILT, now)
        self._state = HomingState.HOMING
        self._homing_done_at = now + self._homing_seconds

    def set_tilt(self, angle: float, now: float) -> None:
        """Tilt to `angle` radians from home; before homing is done this lands wrong."""
        if self.homing_state(now) != HomingState.DONE:
            self._state = HomingState.NOT_STARTED
            angle += UNHOMED_ERROR
        self._go(min(max(angle, TILT_LIMITS[0]), TILT_LIMITS[1]), now)

    def homing_state(self, now: float) -> int:
        if self._state == HomingState.HOMING and now >= self._homing_done_at:
            self._state = HomingState.DONE
            self._from = self._target = HOME_TILT
        return self._state

    def angle(self, now: float) -> float:
        """The current tilt in radians from home."""
        if self.homing_state(now) == HomingState.HOMING:
            # Searching for home takes the whole sequence, however close the head was.
            share = 1 - (self._homing_done_at - now) / self._homing_seconds
            return self._from + (HOME_TILT - self._from) * min(1.0, max(0.0, share))
        travel = self._speed * (now - self._since)
        if self._target >= self._from:
            return min(self._from + travel, self._target)
        return max(self._from - travel, self._target)

    def _go(self, target: float, now: float) -> None:
        self._from = self.angle(now)
        self._target = target
        self._since = now
