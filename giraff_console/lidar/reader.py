"""The lidar read on its own thread: whole revolutions, the latest kept, each handed on.

One owned thread (an exit event, joined at `close`) opens the port, asks the sensor
who it is and how it is, starts a normal scan and assembles the samples into
revolutions (lidar/scan.py). The missions read the latest with `readings()`; mapping
subscribes and hears every revolution with its time.

Whatever goes wrong on the line is said, never raised into the caller: the status is a
typed value (`LidarStatus`), the operator hears a note when it changes, and the thread
opens the port again after a wait that doubles up to MAX_BACKOFF_S. Every read has the
port's timeout, so nothing hangs on a silent sensor; bytes out of step (a sample's
start flags or check bit wrong, protocol/rplidar.py) are stepped over one at a time
until whole samples come again, and the revolution they fell in is dropped. Samples
lost between whole ones leave a revolution with a gap, or two turns run together: a
reader that fell behind drops what piled up beyond MAX_BUFFERED (whole samples, so the
line stays in step), the simulator what its host did not read. Such a revolution is
handed on marked not `whole` (lidar/scan.py), for the obstacle sensing to look at but
not for a map, a fix or a doorway to be drawn from. A scan
older than `stale_s` is not handed to the missions: `readings()` then says nothing is
known (no beams) rather than what was there a while ago.
"""

from __future__ import annotations

import contextlib
import enum
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import serial
from adafruit_rplidar import SCAN_TYPE_NORMAL, RPLidarException

from giraff_console.lidar.device import LineSilent, Opener, RplidarDevice
from giraff_console.lidar.scan import LidarScan, Mount, robot_beams, whole_turn
from giraff_console.protocol.rplidar import SAMPLE_LEN, Health

log = logging.getLogger(__name__)

# Waits before opening the port again, doubling from the first to the last.
FIRST_BACKOFF_S = 0.2
MAX_BACKOFF_S = 5.0
# A revolution with fewer samples than this is a fragment (the first one after the
# scan starts, or one cut by garbled bytes), not a scan.
MIN_SAMPLES = 16
# The most samples one revolution may hold before it is taken as a runaway (no start
# flag seen): an A3 gives about 1600 at its slowest.
MAX_SAMPLES = 4000
# Bytes stepped over in a row before the stream is given up and the port opened again:
# two revolutions of an A1's samples.
MAX_SKIPPED = 2 * 360 * SAMPLE_LEN
# Samples let pile up unread before they are dropped (about two A1 revolutions): a
# reader that falls behind skips ahead rather than lagging for ever.
MAX_BUFFERED = 720


class LidarState(enum.Enum):
    STARTING = "starting"
    SCANNING = "scanning"
    LOST = "lost"  # the port cannot be opened, went away, or fell silent
    UNHEALTHY = "unhealthy"  # the sensor says it is in protection stop
    CLOSED = "closed"


@dataclass(frozen=True)
class LidarStatus:
    state: LidarState
    detail: str = ""
    health: Health | None = None
    error_code: int = 0


@dataclass(frozen=True)
class ReaderSettings:
    """How the reader reads: the sensor's range limits and its mount."""

    mount: Mount = field(default_factory=Mount)
    range_min: float = 0.15
    range_max: float = 12.0
    timeout: float = 1.0
    stale_s: float = 1.0


class LidarReader:
    """One RPLIDAR on one port, read on an owned thread until `close`."""

    def __init__(self, opener: Opener, name: str, baudrate: int = 115200,
                 settings: ReaderSettings = ReaderSettings(),
                 notes: Callable[[str], None] = lambda text: None,
                 clock: Callable[[], float] = time.monotonic) -> None:  # fmt: skip
        self.opener = opener
        self.name = name
        self.baudrate = baudrate
        self.settings = settings
        self.notes = notes
        self.clock = clock
        self._lock = threading.Lock()
        self._latest: LidarScan | None = None
        self._status = LidarStatus(LidarState.STARTING)
        self._listeners: list[Callable[[LidarScan], None]] = []
        self._exit = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lidar", daemon=True)
        self.revolutions = 0
        self.skipped_bytes = 0

    # -- what others call ---------------------------------------------------------------

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        """Stop reading, join the thread, and close the port."""
        self._exit.set()
        if self._thread.is_alive():
            self._thread.join(timeout=self.settings.timeout + 2.0)
        self._set_status(LidarStatus(LidarState.CLOSED))

    @property
    def status(self) -> LidarStatus:
        return self._status

    def latest(self) -> LidarScan | None:
        """The last revolution, however old."""
        return self._latest

    def readings(self) -> LidarScan:
        """The last revolution, if it is fresh; else a scan with no beams, which
        says nothing either way (missions/lookout.py then changes nothing)."""
        scan = self._latest
        if scan is None or self.clock() - scan.taken_at > self.settings.stale_s:
            return LidarScan(self.settings.range_max, (), self.clock(), 0)
        return scan

    def subscribe(self, listener: Callable[[LidarScan], None]) -> None:
        """`listener` hears every revolution, on the reader's thread: it must be
        quick, or hand the scan on (a queue)."""
        with self._lock:
            self._listeners.append(listener)

    def unsubscribe(self, listener: Callable[[LidarScan], None]) -> None:
        """`listener` hears no more revolutions (one being handed out may still reach it)."""
        with self._lock:
            self._listeners = [other for other in self._listeners if other != listener]

    # -- the thread ---------------------------------------------------------------------

    def _run(self) -> None:
        backoff = FIRST_BACKOFF_S
        while not self._exit.is_set():
            device: RplidarDevice | None = None
            try:
                device = RplidarDevice(self.opener, self.name, self.baudrate,
                                       self.settings.timeout)  # fmt: skip
                if self._healthy(device):
                    # Scanning again: the next loss waits the shortest time first.
                    backoff = FIRST_BACKOFF_S
                    device.start(SCAN_TYPE_NORMAL)
                    self._read_scans(device)
            except LineSilent as error:
                self._set_status(LidarStatus(LidarState.LOST, f"the sensor is silent: {error}"))
            except (RPLidarException, serial.SerialException, OSError, ValueError) as error:
                self._set_status(LidarStatus(LidarState.LOST, str(error) or type(error).__name__))
            except Exception as error:
                # A bug (ours, or the package's): the sensor is said lost, never silently
                # left for dead while the missions drive on without it; read again.
                log.exception("lidar: reading failed")
                self._set_status(LidarStatus(LidarState.LOST, f"internal error: {error!r}"))
            finally:
                if device is not None:
                    self._let_go(device)
            if self._exit.wait(backoff):
                break
            backoff = min(2 * backoff, MAX_BACKOFF_S)

    def _healthy(self, device: RplidarDevice) -> bool:
        """Whether the sensor says it can scan; a protection stop is reset once, as its
        protocol document advises, and reported if it stays."""
        info = device.info
        health, code = device.health_status()
        if health == Health.ERROR:
            device.reset()
            health, code = device.health_status()
        if health == Health.ERROR:
            self._set_status(LidarStatus(LidarState.UNHEALTHY, f"protection stop, error code "
                                         f"{code:#06x}", health, code))  # fmt: skip
            return False
        firmware = ".".join(str(part) for part in info["firmware"])
        detail = f"model {info['model']:#04x}, firmware {firmware}"
        if health == Health.WARNING:
            detail += f"; it warns of error code {code:#06x}"
        if not device.motor_line:
            detail += "; no DTR line for the motor (a pseudo-terminal)"
        self._set_status(LidarStatus(LidarState.SCANNING, detail, health, code))
        return True

    def _read_scans(self, device: RplidarDevice) -> None:
        """Samples into revolutions until told to stop; raises when the line fails."""
        angles: list[float] = []
        distances: list[float] = []
        qualities: list[int] = []
        skipped = 0
        whole = False  # whether the revolution under way started at its start flag
        lost = False  # whether samples of it were dropped, unread
        while not self._exit.is_set():
            try:
                # The backlog is dropped here, not by the package (its max_buf_meas):
                # so the revolution it falls in is known to have lost samples.
                for new_scan, quality, angle, distance in device.iter_measurements(0):
                    skipped = 0
                    if new_scan:
                        if whole and len(angles) >= MIN_SAMPLES:
                            self._publish(angles, distances, qualities, intact=not lost)
                        angles, distances, qualities = [], [], []
                        whole, lost = True, False
                    angles.append(angle)
                    distances.append(distance)
                    qualities.append(quality or 0)
                    if len(angles) > MAX_SAMPLES:
                        raise RPLidarException("a revolution with no start: not a scan")
                    if self._exit.is_set():
                        return
                    if device.drop_backlog(MAX_BUFFERED):
                        lost = True
            except LineSilent:
                raise
            except RPLidarException:
                # Out of step: one byte on, and this revolution is not to be trusted.
                skipped += 1
                self.skipped_bytes += 1
                if skipped > MAX_SKIPPED:
                    raise RPLidarException("no whole samples on the line") from None
                device.skip(1)
                angles, distances, qualities, whole = [], [], [], False

    def _publish(self, angles: list[float], distances: list[float], qualities: list[int],
                 intact: bool) -> None:  # fmt: skip
        """Hand a revolution on; `intact`: none of its samples were dropped unread."""
        settings = self.settings
        angle_deg, distance_mm = np.array(angles), np.array(distances)
        beams = robot_beams(angle_deg, distance_mm, np.array(qualities),
                            settings.mount, settings.range_min, settings.range_max)  # fmt: skip
        whole = intact and whole_turn(angle_deg, distance_mm > 0)
        scan = LidarScan(settings.range_max, beams, self.clock(), len(angles), whole)
        self._latest = scan
        self.revolutions += 1
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(scan)
            except Exception:
                # One listener's bug (mapping, say) must not stop the others' scans,
                # nor the obstacle sensing that reads the latest.
                log.exception("lidar: a listener failed")

    def _let_go(self, device: RplidarDevice) -> None:
        """Stop the scan and the motor, and close the port; a line already gone is let
        go of quietly."""
        try:
            if device.scanning:
                device.stop()
            device.stop_motor()
        except (RPLidarException, LineSilent, serial.SerialException, OSError):
            pass
        finally:
            with contextlib.suppress(serial.SerialException, OSError):
                device.disconnect()

    def _set_status(self, status: LidarStatus) -> None:
        before, self._status = self._status, status
        if status.state != before.state or status.detail != before.detail:
            self.notes(f"lidar {self.name}: {status.state.value}"
                       + (f": {status.detail}" if status.detail else ""))  # fmt: skip
