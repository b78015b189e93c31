"""Writing the session log without ever holding up the control loop.

The original wrote its log from the motor thread and saw lag spikes on a USB stick
(§5.3); the thesis suggests moving the writing out, as was done for video (§3.4.1).
Here the control loop only queues a line. A writer thread writes and flushes every line
at once, so a crash loses at most what is still queued (milliseconds), and fsyncs at
least once a second, so a power loss loses at most a second. A full disk, or any other
write error, stops the log with a message; the loop never sees it.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path

from giraff_console.private_files import open_private

# The bound on what a power loss may take away.
FSYNC_INTERVAL_S = 1.0


class LogWriter:
    """Appends lines to a file from its own thread."""

    def __init__(self, path: Path, on_error: Callable[[str], None] = lambda message: None,
                 fsync_interval: float = FSYNC_INTERVAL_S) -> None:  # fmt: skip
        """Open `path` for writing; OSError if it cannot be created."""
        self.path = path
        self.on_error = on_error
        self.fsync_interval = fsync_interval
        self.written = 0
        self.error: str | None = None
        self._file = open_private(path, "w", encoding="utf-8", newline="\n")
        self._queue: queue.SimpleQueue[str | None] = queue.SimpleQueue()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="log-writer", daemon=True)
        self._thread.start()

    def write(self, line: str) -> None:
        """Queue one line (without its line end); never blocks, never raises."""
        if not self._closed and self.error is None:
            self._queue.put(line)

    def close(self) -> None:
        """Write what is queued, fsync and close."""
        if self._closed:
            return
        self._closed = True
        self._queue.put(None)
        self._thread.join()

    def _run(self) -> None:
        synced_at = time.monotonic()
        dirty = False
        try:
            while True:
                # With lines not yet on disk, wake no later than their fsync is due.
                due = synced_at + self.fsync_interval - time.monotonic()
                try:
                    line = self._queue.get(timeout=max(0.0, due) if dirty else None)
                except queue.Empty:
                    line = ""
                if line is None:
                    break
                if line:
                    self._file.write(line + "\n")
                    self._file.flush()
                    self.written += 1
                    dirty = True
                if dirty and time.monotonic() - synced_at >= self.fsync_interval:
                    os.fsync(self._file.fileno())
                    synced_at, dirty = time.monotonic(), False
            self._file.flush()
            os.fsync(self._file.fileno())
        except OSError as error:
            self.error = f"recording stopped: cannot write {self.path}: {error.strerror or error}"
            self.on_error(self.error)
        finally:
            # On a full disk what was flushed is kept; the rest is lost whatever we do.
            with contextlib.suppress(OSError):
                self._file.close()
