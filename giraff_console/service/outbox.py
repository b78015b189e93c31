"""What the daemon has yet to tell one console, waiting for that console's writer.

The control loop and the service drop events in here and never wait (a console that
stops reading must not delay a tick, issue 15). Telemetry comes twenty times a second
and only the newest matters, so a console that falls behind gets the latest snapshot,
not the history; so do the camera's frames, to a console that asked for them, and the
pictures of a map being built (issue 29), each the whole map so far.
Everything else (answers, notes, who holds the controls, a mission's end) matters each
time: none of it is dropped, and a console so far behind that LIMIT of those wait is
hung up on instead, which lets go of its keys like any hang-up.
"""

from __future__ import annotations

import collections
import threading

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service.events import MapDrawn

# Messages other than telemetry a console may fall behind by before it is hung up on.
LIMIT = 2000


class Outbox:
    """Safe from any thread; `take` is for the one writer."""

    def __init__(self, limit: int = LIMIT) -> None:
        self.limit = limit
        self._ready = threading.Condition()
        self._messages: collections.deque[object] = collections.deque()
        self._latest: Telemetry | None = None
        # The camera's frames, for a console that shows them (it asked, c.View): only
        # the newest, as for telemetry, so that one that stops reading drops frames and
        # holds up nothing (issue 26).
        self.wants_frames = False
        self._frame: SharedFrame | None = None
        self._map: MapDrawn | None = None
        self._took_snapshot = False
        self._closed = False
        self.overflowed = False

    def put(self, message: object) -> None:
        """Never waits."""
        with self._ready:
            if self._closed:
                return
            if isinstance(message, Telemetry):
                self._latest = message
            elif isinstance(message, SharedFrame):
                if self.wants_frames:
                    self._frame = message
            elif isinstance(message, MapDrawn):
                self._map = message
            elif len(self._messages) >= self.limit:
                self.overflowed = self._closed = True
            else:
                self._messages.append(message)
            self._ready.notify()

    def close(self) -> None:
        """No more: `take` returns None once what is queued has been taken."""
        with self._ready:
            self._closed = True
            self._ready.notify()

    def take(self, timeout: float) -> object | None:
        """The next message, in order, the newest telemetry after the others; None when
        closed and empty, or after `timeout` seconds with nothing."""
        with self._ready:
            self._ready.wait_for(
                lambda: self._messages or self._latest is not None or self._map is not None
                or self._frame is not None or self._closed, timeout,
            )  # fmt: skip
            if self._messages:
                return self._messages.popleft()
            if self.overflowed:
                return None
            if self._map is not None:
                drawn, self._map = self._map, None
                return drawn
            # A snapshot and a frame by turns: a console that reads slowly gets both,
            # each the newest, rather than snapshots alone.
            frame_first = self._frame is not None and (self._latest is None or self._took_snapshot)
            if frame_first:
                frame, self._frame = self._frame, None
                self._took_snapshot = False
                return frame
            latest, self._latest = self._latest, None
            self._took_snapshot = latest is not None
            return latest

    @property
    def pending(self) -> bool:
        """Whether anything waits to be taken."""
        with self._ready:
            return bool(self._messages or self._latest is not None or self._map is not None
                        or self._frame is not None)  # fmt: skip

    @property
    def closed(self) -> bool:
        with self._ready:
            return self._closed and not self._messages
