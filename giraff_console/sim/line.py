"""The simulated board at the far end of a serial line: bytes in, paced replies out.

Both ways of reaching the simulator, the in-process pyserial handler and the
pseudo-terminal server, move bytes through a `BoardLine`.
"""

from __future__ import annotations

from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.pacing import PacedStream

# The board's input buffer; longer lines are cut, as a small AVR's would be.
MAX_COMMAND_BYTES = 256


class BoardLine:
    """Assembles commands from the host, runs them on the board, queues the replies."""

    def __init__(self, board: GiraffBoard, paced: bool) -> None:
        self.board = board
        self.to_board = PacedStream(paced)
        self.to_host = PacedStream(paced)
        self._partial = bytearray()

    def receive(self, data: bytes, now: float) -> None:
        """Bytes written by the host at `now`; they reach the board at line rate."""
        self.to_board.push(data, now)

    def pump(self, now: float) -> None:
        """Run every command whose CR has reached the board by `now`."""
        for byte in self.to_board.pop_due(now):
            if byte == 0x0D:
                line = self._partial.decode("ascii", "replace")
                self._partial.clear()
                self.to_host.push(self.board.execute(line), now)
            elif byte != 0x0A and len(self._partial) < MAX_COMMAND_BYTES:
                # A stray LF (a host sending CR LF) is ignored rather than answered.
                self._partial.append(byte)

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

    def next_event(self, whole_lines: bool) -> float | None:
        """When something next happens on the line, or None if nothing is in flight."""
        times = [
            self.to_board.due_time(b"\r" if whole_lines else None),
            self.to_host.due_time(b"\n" if whole_lines else None),
        ]
        pending = [t for t in times if t is not None]
        return min(pending) if pending else None
