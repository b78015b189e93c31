"""The RPLIDAR's requests and replies through adafruit-circuitpython-rplidar.

Why that package: it is maintained (1.2.21, 2026), MIT, pure Python over pyserial, and
speaks the A1/A2's normal scan; `rplidar` and `rplidar-roboticia` (2017) and
`pyrplidar` (2019) are not maintained. What its source shows, and what is done here:

- Given a port *name* it opens `serial.Serial` itself (given an object, its `connect`
  assigns a local and loses it). So it is given the name, and `connect` is overridden
  to open the port the project's way: `serial_for_url`, which also reaches the
  simulated sensor (`giraff-lidar://`), or an opener the caller gives.
- An A1's motor follows DTR, which `_control_motor` sets. A pseudo-terminal has no
  modem lines, and pyserial's ioctl for them fails there (the board's simulator has
  sim/modem_shim.py for C drivers for the same reason): the failure is kept, not
  raised, so the same code drives a real sensor and the simulator's pty.
- A reply cut short by the port's timeout is raised as `LineSilent`, so the reader
  tells a silent line from a garbled one by type.
- Express scans are buggy there (they decode the wrong way round): normal scans only.
"""

from __future__ import annotations

from collections.abc import Callable

import serial
from adafruit_rplidar import RPLidar, RPLidarException

from giraff_console.protocol.rplidar import SAMPLE_LEN, Health

# The package's words for GET_HEALTH's status, as the protocol's values.
HEALTH_WORDS = {"Good": Health.GOOD, "Warning": Health.WARNING, "Error": Health.ERROR}

Opener = Callable[[], serial.SerialBase]


class LineSilent(Exception):
    """Nothing, or not enough, came within the port's timeout."""


class RplidarDevice(RPLidar):
    """The package's `RPLidar`, opening its port through `opener`."""

    _serial_port: serial.SerialBase | None

    def __init__(self, opener: Opener, name: str, baudrate: int, timeout: float) -> None:
        self._opener = opener
        self.motor_line = True  # whether DTR could be set (False on a pty)
        try:
            super().__init__(None, name, baudrate=baudrate, timeout=timeout)
        except BaseException:
            self.disconnect()  # the port opened, then the motor's request failed
            raise

    def connect(self) -> None:
        if self._serial_port is not None:
            self.disconnect()
        try:
            self._serial_port = self._opener()
        except (serial.SerialException, OSError, ValueError) as error:
            raise RPLidarException(f"cannot open the lidar's port: {error}") from None

    def disconnect(self) -> None:
        port: serial.SerialBase | None = self._serial_port
        self._serial_port = None
        if port is not None:
            port.close()

    def _control_motor(self, val: bool) -> None:
        try:
            super()._control_motor(val)
        except (OSError, serial.SerialException):
            self.motor_line = False  # a pseudo-terminal: the simulated motor always turns

    def _read_response(self, dsize: int) -> bytes:
        data = self._port().read(dsize)
        if len(data) != dsize:
            raise LineSilent(f"{len(data)} of {dsize} bytes within {self.timeout:g} s")
        return data

    def health_status(self) -> tuple[Health, int]:
        """GET_HEALTH: the status and its error code. RPLidarException for a reply that
        is not one, LineSilent for none."""
        try:
            words, code = self.health
        except KeyError:  # a status byte the protocol does not have: a garbled reply
            raise RPLidarException("a health reply with an unknown status") from None
        return HEALTH_WORDS[words], code

    def drop_backlog(self, most: int) -> bool:
        """Drop the whole samples waiting unread if more than `most` are (as the
        package's own max_buf_meas would, but said); whether any were dropped."""
        port = self._port()
        waiting = port.in_waiting
        if waiting <= most * SAMPLE_LEN:
            return False
        port.read(waiting // SAMPLE_LEN * SAMPLE_LEN)
        return True

    def skip(self, count: int) -> None:
        """Drop `count` bytes of the stream: a step towards the next whole sample."""
        self._port().read(count)

    def _port(self) -> serial.SerialBase:
        if self._serial_port is None:
            raise RPLidarException("the lidar's port is not open")
        return self._serial_port


def open_named(name: str, baudrate: int, timeout: float) -> Opener:
    """An opener for a device path or any pyserial URL."""
    return lambda: serial.serial_for_url(name, baudrate, timeout=timeout)
