"""The simulated board at the far end of a serial line: bytes in, paced replies out.

Both ways of reaching the simulator, the in-process pyserial handler and the
pseudo-terminal server, move bytes through a `BoardLine`.
"""

from __future__ import annotations

import logging

from giraff_console.protocol.framing import LINE_END, PROMPT
from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.pacing import PacedStream

log = logging.getLogger(__name__)

# The board's input buffer; a longer line is refused whole rather than run in part.
MAX_COMMAND_BYTES = 256
_TOO_LONG = b"Error: Line too long\r\n" + PROMPT.encode() + LINE_END
_FAULT = b"ERROR: simulator fault\r\n" + PROMPT.encode() + LINE_END


class BoardLine:
    """Assembles commands from the host, runs them on the board, queues the replies."""

    def __init__(self, board: GiraffBoard, paced: bool) -> None:
        self.board = board
        self.to_board = PacedStream(paced)
        self.to_host = PacedStream(paced)
        self._partial = bytearray()
        self._overflow = False

    def receive(self, data: bytes, now: float) -> None:
        """Bytes written by the host at `now`; they reach the board at line rate."""
        self.to_board.push(data, now)

    def pump(self, now: float) -> None:
        """Run every command whose CR has reached the board by `now`."""
        for byte in self.to_board.pop_due(now):
            if byte == 0x0D:
                self.to_host.push(self._answer(), now)
            elif byte == 0x0A:
                continue  # a stray LF (a host sending CR LF) is ignored, not answered
            elif len(self._partial) < MAX_COMMAND_BYTES:
                self._partial.append(byte)
            else:
                self._overflow = True

    def _answer(self) -> bytes:
        line = self._partial.decode("ascii", "replace")
        overflow, self._overflow = self._overflow, False
        self._partial.clear()
        if overflow:
            return _TOO_LONG
        try:
            return self.board.execute(line)
        except Exception:
            # Whatever a client sends, a simulator serving it must not die of it.
            log.exception("simulator fault on %r", line)
            return _FAULT

    def power_on(self, now: float) -> None:
        """The board boots and greets (A.3)."""
        self.to_host.push(self.board.greeting(), now)

    def power_off(self) -> None:
        """The board loses power: it stops, and everything in flight is lost."""
        self.board.power_off()
        self.drop_traffic()

    def drop_traffic(self) -> None:
        """Forget bytes in flight both ways, as when the other end goes away."""
        self.to_board.clear()
        self.to_host.clear()
        self._partial.clear()
        self._overflow = False

    def next_event(self, whole_lines: bool) -> float | None:
        """When something next happens on the line, or None if nothing is in flight."""
        times = [
            self.to_board.due_time(b"\r" if whole_lines else None),
            self.to_host.due_time(b"\n" if whole_lines else None),
        ]
        pending = [t for t in times if t is not None]
        return min(pending) if pending else None
