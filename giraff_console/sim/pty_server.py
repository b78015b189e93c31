"""The simulated board on a pseudo-terminal, for any serial program in any language.

The server holds the pty's master side. It watches for a program opening the slave
side, which stands in for the host raising the board's power line: the board then
greets after a short boot delay. The board keeps running when the program goes away,
moves and all, because the board carries on with the last `set p` when its driver
dies (wire-facts); that is the case the console's safety rules are written for.
"""

from __future__ import annotations

import contextlib
import os
import select
import termios
import tty

from giraff_console.clock import RealClock
from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.line import BoardLine

# Time from the port being opened to the banner. Long enough for the opening program to
# finish configuring and flushing the port (pyserial flushes input when it opens).
BOOT_DELAY_S = 0.05
# With no program on the slave side the master reports a hang-up on every poll, so the
# server checks for a new connection at this interval instead. A program that closes
# and reopens the port faster than this is not greeted again; the link then probes.
IDLE_POLL_S = 0.02


class PtyServer:
    """Serves a `GiraffBoard` on a new pseudo-terminal until stopped."""

    def __init__(self, board: GiraffBoard, paced: bool = False) -> None:
        if not isinstance(board.clock, RealClock):
            raise ValueError("a pty server needs a board on the real clock")
        self.board = board
        self.clock = board.clock
        self.line = BoardLine(board, paced)
        self._master, slave = os.openpty()
        # Raw mode, set once on our side: no echo and no CR/LF translation for whoever
        # opens the slave, even a program that does not configure the port itself.
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)
        # Never block on a program that stops reading; hold its bytes back instead.
        os.set_blocking(self._master, False)
        self._unsent = bytearray()
        # stop() may run in a signal handler, so it only sets a flag and writes to a
        # pipe that wakes the loop: a threading.Event could deadlock there.
        self._stop_requested = False
        self._wake_read, self._wake_write = os.pipe()
        os.set_blocking(self._wake_write, False)
        self._connected = False
        self._greet_at: float | None = None

    def stop(self) -> None:
        """Ask `serve_forever` to return; safe from another thread or a signal handler."""
        self._stop_requested = True
        with contextlib.suppress(BlockingIOError):
            os.write(self._wake_write, b"!")

    def close(self) -> None:
        for fd in (self._master, self._wake_read, self._wake_write):
            os.close(fd)

    def serve_forever(self) -> None:
        hangup = select.poll()
        hangup.register(self._master, select.POLLIN)
        while not self._stop_requested:
            now = self.clock.now()
            wake = [t for t in (self.line.next_event(whole_lines=True), self._greet_at) if t]
            timeout = max(0.0, min(wake) - now) if wake else 0.2
            # select() waits to the microsecond; poll() only to the millisecond, which
            # would cost a paced exchange about a millisecond per reply line.
            readable, _, _ = select.select([self._master, self._wake_read], [], [], timeout)
            if self._wake_read in readable:
                continue
            events = hangup.poll(0)
            if events and events[0][1] & select.POLLHUP and not events[0][1] & select.POLLIN:
                self._hang_up()
                select.select([self._wake_read], [], [], IDLE_POLL_S)
                continue
            now = self.clock.now()
            if not self._connected:
                self._connected = True
                self._greet_at = now + BOOT_DELAY_S
            if self._master in readable:
                try:
                    self.line.receive(os.read(self._master, 4096), now)
                except (BlockingIOError, InterruptedError):
                    pass
                except OSError:
                    self._hang_up()
                    continue
            if self._greet_at is not None and now >= self._greet_at:
                self._greet_at = None
                self.line.power_on(now)
            self.line.pump(now)
            self._unsent += self.line.to_host.pop_due(now)
            if self._unsent:
                self._send()

    def _send(self) -> None:
        try:
            written = os.write(self._master, self._unsent)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._hang_up()
            return
        del self._unsent[:written]

    def _hang_up(self) -> None:
        """The program on the slave side went away: forget its traffic, keep the board."""
        if self._connected:
            self._connected = False
            self._greet_at = None
            self._unsent.clear()
            self.line.drop_traffic()
            with contextlib.suppress(termios.error):
                termios.tcflush(self._master, termios.TCIOFLUSH)
