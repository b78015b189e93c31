"""The simulated RPLIDAR on a pseudo-terminal, beside the board's (sim/pty_server.py).

It runs on its own thread, owned: `start`, then `close` stops and joins it. The sensor
stops scanning when the program on the other side goes away, so that the next one
starts from a quiet line, and keeps what it was told otherwise.
"""

from __future__ import annotations

import contextlib
import os
import select
import termios
import threading
import time
import tty

from giraff_console.sim.lidar import SimLidar

# With no program on the slave side the master reports a hang-up on every poll: look
# for a new one this often instead (as the board's server does).
IDLE_POLL_S = 0.02
# The longest the loop sleeps while scanning: samples go out in small bursts, as they
# would trickle down a serial line.
BURST_S = 0.005
# The most held back for a program that stops reading (about three seconds of an A1's
# samples): past it the oldest bytes go, as a host's UART overruns; its reader resyncs.
MAX_UNSENT = 32768


class LidarPtyServer:
    """Serves a `SimLidar` on a new pseudo-terminal, on its own thread."""

    def __init__(self, lidar: SimLidar) -> None:
        self.lidar = lidar
        self._master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: the samples are binary
        self.path = os.ttyname(slave)
        os.close(slave)
        os.set_blocking(self._master, False)
        self._unsent = bytearray()
        self._connected = False
        self._stop = threading.Event()
        self._wake_read, self._wake_write = os.pipe()
        self._thread = threading.Thread(target=self._serve, name="sim-lidar", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        """Stop serving and join the thread; then the pty goes."""
        self._stop.set()
        with contextlib.suppress(OSError):
            os.write(self._wake_write, b"!")
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        for fd in (self._master, self._wake_read, self._wake_write):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _serve(self) -> None:
        hangup = select.poll()
        hangup.register(self._master, select.POLLIN)
        while not self._stop.is_set():
            due = self.lidar.next_due()
            now = time.monotonic()
            timeout = 0.2 if due is None else min(BURST_S, max(0.0, due - now))
            readable, _, _ = select.select([self._master, self._wake_read], [], [], timeout)
            if self._wake_read in readable:
                continue
            events = hangup.poll(0)
            if events and events[0][1] & select.POLLHUP and not events[0][1] & select.POLLIN:
                self._hang_up()
                self._stop.wait(IDLE_POLL_S)
                continue
            self._connected = True
            now = time.monotonic()
            if self._master in readable:
                try:
                    self.lidar.receive(os.read(self._master, 4096), now)
                except (BlockingIOError, InterruptedError):
                    pass
                except OSError:
                    self._hang_up()
                    continue
            self._unsent += self.lidar.pop_due(now)
            if len(self._unsent) > MAX_UNSENT:
                del self._unsent[: len(self._unsent) - MAX_UNSENT]
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
        if self._connected:
            self._connected = False
            self._unsent.clear()
            self.lidar.hang_up()
            with contextlib.suppress(termios.error):
                termios.tcflush(self._master, termios.TCIOFLUSH)
