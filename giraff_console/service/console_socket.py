"""One console's socket as the daemon's event loop holds it: bounded both ways (issue 30).

The daemon reads and writes every console's socket from its one thread and never
waits on one (service/daemon.py), so each console keeps here what is half done:

- the bytes of a request line not yet whole, REQUEST_LINE at most. A request is a few
  hundred bytes (a batch of controller commands, c.MAX_COMMANDS of them, a few
  kilobytes); a longer line is thrown away as it streams in, never parsed;
- the bytes of the message the socket has not yet taken: about one message, since the
  next is taken from the outbox only once those are nearly gone. What the console has
  yet to be told waits in its Outbox, which keeps only the newest telemetry and hangs
  up on a console that falls LIMIT messages behind. A console whose socket takes
  nothing for SEND_TIMEOUT_S is hung up on too (a frozen SSH session);
- its requests that wait for a worker (planning, a controller command waiting for its
  answer): WAITING at most, run one at a time and in the order asked;
- how many requests it may still make: REQUESTS_PER_S, in bursts of up to BURST
  (a held arrow key repeats about 33 times a second, and a heartbeat comes twice).
"""

from __future__ import annotations

import collections
import enum
import socket
from typing import TYPE_CHECKING

from giraff_console.service.outbox import Outbox
from giraff_console.service.transport import SEND_TIMEOUT_S, ConnectionClosed, LineBuffer

if TYPE_CHECKING:
    from giraff_console.service.console_hello import Asked

# A request line's bytes at most: far above any request, far below a message the daemon
# sends (a map, a camera frame), so that parsing one holds the interpreter for well
# under a millisecond.
REQUEST_LINE = 64 * 1024
# Bytes read from one console at one turn of the loop: every console gets its turn.
READ_CHUNK = 16 * 1024
# Below this many bytes not yet written, the next message is taken from the outbox.
WRITE_LOW = 64 * 1024
# Requests waiting for a worker, a console.
WAITING = 8
# A console's requests a second, and a burst of them.
REQUESTS_PER_S = 100.0
BURST = 200.0


class StoppedReading(ConnectionClosed):
    """The console's socket has taken nothing for SEND_TIMEOUT_S."""


class Stage(enum.Enum):
    """Where a connection is: not yet said Hello; welcomed over the connection limit,
    and served only a stop (daemon.py); attached."""

    GREETING = "greeting"
    OVER_LIMIT = "over the limit"
    ATTACHED = "attached"


class ConsoleSocket:
    """A non-blocking client socket and what is half done on it; for one thread."""

    def __init__(self, sock: socket.socket, now: float) -> None:
        sock.setblocking(False)
        self.socket = sock
        self.stage = Stage.GREETING
        self.name = ""  # as the others see it, once attached
        self.since = now  # when it connected, or was welcomed over the limit
        self.outbox = Outbox()
        self.waiting: collections.deque[Asked] = collections.deque()
        self.working = False  # one of its requests is with a worker
        self.closing = False  # hung up on once what it has been sent has gone
        self.gone = False
        self._lines = LineBuffer(REQUEST_LINE)
        self._unsent = bytearray()
        self._stuck_since: float | None = None
        self._tokens = BURST
        self._tokens_at = now

    def fileno(self) -> int:
        return self.socket.fileno()

    def read(self) -> None:
        """What the socket has, up to READ_CHUNK; ConnectionClosed at its end."""
        try:
            chunk = self.socket.recv(READ_CHUNK)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as error:
            raise ConnectionClosed(f"peer gone ({error.strerror or error})") from None
        if not chunk:
            raise ConnectionClosed("peer closed the connection")
        self._lines.add(chunk)

    def line(self) -> bytes | None:
        """The next whole request line, or None; WireError for one over REQUEST_LINE."""
        return self._lines.take()

    def queue(self, line: bytes) -> None:
        """`line` to be written after what is already waiting."""
        self._unsent += line

    @property
    def wants_more(self) -> bool:
        """Whether the next message may be taken from the outbox."""
        return len(self._unsent) < WRITE_LOW

    @property
    def unsent(self) -> bool:
        return bool(self._unsent)

    def write(self, now: float) -> None:
        """As much of what waits as the socket takes now; ConnectionClosed if the peer
        has gone, StoppedReading if it has taken nothing for SEND_TIMEOUT_S."""
        if self._unsent:
            try:
                sent = self.socket.send(self._unsent)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError as error:  # BrokenPipe, ConnectionReset
                raise ConnectionClosed(f"peer gone ({error.strerror or error})") from None
            del self._unsent[:sent]
            if sent:
                self._stuck_since = None
        if not self._unsent:
            self._stuck_since = None
        elif self._stuck_since is None:
            self._stuck_since = now
        self.check_stuck(now)

    def check_stuck(self, now: float) -> None:
        if self._stuck_since is not None and now - self._stuck_since > SEND_TIMEOUT_S:
            raise StoppedReading("peer not reading")

    def allowed(self, now: float) -> bool:
        """Whether one more request is within the console's rate (a token is taken)."""
        self._tokens = min(BURST, self._tokens + (now - self._tokens_at) * REQUESTS_PER_S)
        self._tokens_at = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True

    def close(self) -> None:
        self.gone = True
        self.outbox.close()
        self.socket.close()
