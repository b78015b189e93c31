"""Hold-to-move over a terminal: a held key recognised from auto-repeat alone.

Terminals send no key-release events, over SSH least of all. A held key is a first
press, then, after the terminal's initial repeat delay (about half a second), a stream
of repeats. The deadman therefore has two stages: after the first press it waits a
grace period that covers the initial delay; once repeats have started, a short gap
between them means the key was let go. Either way, silence stops the robot.
"""

from __future__ import annotations

import enum
import threading

from giraff_console.clock import Clock

# Covers the usual initial repeat delays: 500 ms in most terminals, 660 ms in X.org.
DEFAULT_GRACE_S = 0.7
# Repeats come every 30-40 ms; this allows for jitter over a slow SSH link.
DEFAULT_REPEAT_TIMEOUT_S = 0.15


class Intent(enum.Enum):
    """What the operator asks of the wheels: (motion, turn), each -1, 0 or +1.

    Turn +1 is to the right, clockwise, like a positive `set p` in rotation (A.2.2).
    """

    FORWARD = (1, 0)
    BACKWARD = (-1, 0)
    LEFT = (0, -1)
    RIGHT = (0, 1)
    FORWARD_LEFT = (1, -1)
    FORWARD_RIGHT = (1, 1)

    @property
    def motion(self) -> int:
        return self.value[0]

    @property
    def turn(self) -> int:
        return self.value[1]


class Deadman:
    """Tracks the held key; thread-safe, since keys and the control loop run apart."""

    def __init__(self, clock: Clock, grace: float = DEFAULT_GRACE_S,
                 repeat_timeout: float = DEFAULT_REPEAT_TIMEOUT_S) -> None:  # fmt: skip
        if grace <= 0 or repeat_timeout <= 0:
            raise ValueError("deadman times must be positive")
        self.clock = clock
        self.grace = grace
        self.repeat_timeout = repeat_timeout
        self._lock = threading.Lock()
        self._intent: Intent | None = None
        self._last = 0.0
        self._repeating = False

    def press(self, intent: Intent) -> bool:
        """A key event: a first press, or a repeat of the key already held.

        Returns True for a first press, which the caller may want to act on at once.
        """
        with self._lock:
            now = self.clock.now()
            first = intent is not self._intent or self._expired(now)
            if first:
                self._intent = intent
            self._repeating = not first
            self._last = now
            return first

    def release(self) -> None:
        """Let go at once, as a stop key does."""
        with self._lock:
            self._intent = None

    def held(self) -> Intent | None:
        """The intent still held now, or None once the deadman has expired."""
        with self._lock:
            if self._intent is not None and self._expired(self.clock.now()):
                self._intent = None
            return self._intent

    def _expired(self, now: float) -> bool:
        window = self.repeat_timeout if self._repeating else self.grace
        return now - self._last > window
