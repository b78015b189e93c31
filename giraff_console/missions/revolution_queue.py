"""Revolutions handed from the range sensor's thread to a worker of their own: laid into
a map (mapping.py) or fitted to one (scan_fixing.py) in milliseconds each, never on the
sensor's thread, which must keep reading, nor on the control loop's, which must tick on
time (design.md). The newest few wait; when more come than are worked through, the
oldest are dropped, and counted.
"""

from __future__ import annotations

import collections
import logging
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

# Seconds the worker waits for a revolution before it looks whether to stop.
WAIT_S = 0.2
# Seconds `close` waits for the worker to end (a revolution takes milliseconds).
JOIN_S = 5.0

Revolution = TypeVar("Revolution")


class RevolutionQueue(Generic[Revolution]):
    """`work` called with each revolution `put`, in order, on a thread named `name`; at
    most `keep` waiting. An exception from `work` is a bug: logged, `failed` is told,
    and the queue stops."""

    def __init__(self, name: str, keep: int, work: Callable[[Revolution], None],
                 failed: Callable[[], None]) -> None:  # fmt: skip
        self.work = work
        self.failed = failed
        self.dropped = 0
        self._waiting: collections.deque[Revolution] = collections.deque(maxlen=keep)
        self._ready = threading.Condition()
        self._running = True
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, revolution: Revolution) -> None:
        """From any thread: queued, never waited on."""
        with self._ready:
            if len(self._waiting) == self._waiting.maxlen:
                self.dropped += 1
            self._waiting.append(revolution)
            self._ready.notify()

    def stop(self) -> None:
        """No more work, from any thread (the worker's own too); what waits is dropped."""
        with self._ready:
            self._running = False
            self._ready.notify()

    def close(self) -> None:
        """Stop, and wait for the worker to end."""
        self.stop()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=JOIN_S)

    def _run(self) -> None:
        while True:
            with self._ready:
                if not self._waiting and self._running:
                    self._ready.wait(WAIT_S)
                if not self._running:
                    return
                if not self._waiting:
                    continue
                revolution = self._waiting.popleft()
            try:
                self.work(revolution)
            except Exception:
                log.exception("%s failed", self._thread.name)
                self.stop()
                self.failed()
                return
