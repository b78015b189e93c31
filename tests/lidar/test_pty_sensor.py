"""The simulated RPLIDAR in another process (`giraff-console sim --pty --lidar`), read
through the console's reading code from its pty, as a real sensor would be."""

from __future__ import annotations

import math
import signal
import threading
import time

import pytest

from giraff_console.lidar.device import open_named
from giraff_console.lidar.reader import LidarState
from giraff_console.lidar.scan import LidarScan
from giraff_console.protocol.rplidar import Health
from tests.lidar.conftest import TWO_ROOMS, scanning, wait_for

pytestmark = pytest.mark.pty


def beam_at(scan: LidarScan, bearing: float) -> float:
    """The distance of the beam nearest `bearing` (radians)."""
    return min(scan.beams, key=lambda beam: abs(math.remainder(beam[1] - bearing, math.tau)))[0]


@pytest.mark.parametrize(("rate", "samples"), [(5.5, 360), (10.0, 400)])
def test_revolutions_come_at_the_rate_asked_with_every_sample(lidar_sim, readers, rate, samples):
    sim = lidar_sim("--floorplan", str(TWO_ROOMS), "--lidar-rate", str(rate),
                    "--lidar-samples", str(samples))  # fmt: skip
    times: list[float] = []
    counts: list[int] = []
    reader = readers(sim.lidar)
    reader.subscribe(lambda scan: (times.append(scan.taken_at), counts.append(scan.samples)))
    assert wait_for(lambda: len(times) >= 12, 10.0), reader.status
    measured = (len(times) - 2) / (times[-1] - times[1])
    assert measured == pytest.approx(rate, rel=0.1)
    assert min(counts[1:]) >= samples and max(counts) <= samples


def test_distances_to_the_walls_from_the_true_pose(lidar_sim, readers):
    # The robot stands at (1, 1) facing +x in a 5 x 3 m hall: the wall behind and the
    # one to its right 1 m away, the one to its left 2 m, the one ahead 4 m.
    sim = lidar_sim("--floorplan", str(TWO_ROOMS))
    reader = readers(sim.lidar)
    assert wait_for(lambda: scanning(reader), 10.0), reader.status
    scan = reader.readings()
    assert len(scan.beams) >= 360
    assert beam_at(scan, 0.0) == pytest.approx(4.0, abs=0.01)
    assert beam_at(scan, math.pi) == pytest.approx(1.0, abs=0.01)
    # A wall on the robot's left is at a positive bearing (counter-clockwise), though
    # the sensor's own angles grow clockwise.
    assert beam_at(scan, math.pi / 2) == pytest.approx(2.0, abs=0.01)
    assert beam_at(scan, -math.pi / 2) == pytest.approx(1.0, abs=0.01)
    # 45 degrees to the left, the left-hand wall 2 m away: 2 sqrt(2) m along the beam.
    assert beam_at(scan, math.pi / 4) == pytest.approx(2 * math.sqrt(2), abs=0.01)


class NoisyLine:
    """The real pty's port, with a burst of line noise let in once the scan runs."""

    def __init__(self, port, noise: bytes, after_reads: int) -> None:
        self._port = port
        self._noise = noise
        self._after = after_reads
        self.injected = False

    def read(self, size: int = 1) -> bytes:
        self._after -= 1
        if self._after == 0:
            self.injected = True
            return (self._noise + self._port.read(size))[:size]
        return self._port.read(size)

    def __getattr__(self, name: str):
        return getattr(self._port, name)

    def __setattr__(self, name: str, value) -> None:
        if name.startswith("_") or name == "injected":
            object.__setattr__(self, name, value)
        else:
            setattr(self._port, name, value)


def test_garbage_on_the_line_is_stepped_over(lidar_sim, readers):
    sim = lidar_sim("--floorplan", str(TWO_ROOMS))
    lines: list[NoisyLine] = []

    def opener():
        # Three bytes of noise (not a multiple of a sample's five) a second into the scan.
        lines.append(NoisyLine(open_named(sim.lidar, 115200, 0.5)(), b"\x07\xff\x02", 2000))
        return lines[-1]

    reader = readers(sim.lidar, opener=opener)
    assert wait_for(lambda: reader.skipped_bytes > 0, 10.0), reader.status
    before = reader.revolutions
    assert wait_for(lambda: reader.revolutions >= before + 5, 5.0)
    # The same port all along: resynchronised in place, not reopened.
    assert len(lines) == 1 and lines[0].injected
    assert reader.status.state == LidarState.SCANNING
    scan = reader.readings()
    assert beam_at(scan, 0.0) == pytest.approx(4.0, abs=0.01)
    assert all(beam[0] >= 0.15 for beam in scan.beams)


def test_a_killed_simulator_is_reported_lost_without_a_hang(lidar_sim, readers):
    sim = lidar_sim("--floorplan", str(TWO_ROOMS))
    notes: list[str] = []
    crashes: list[object] = []
    threading.excepthook, before = (lambda args: crashes.append(args)), threading.excepthook
    try:
        reader = readers(sim.lidar, notes=notes.append)
        assert wait_for(lambda: scanning(reader), 10.0), reader.status
        sim.process.send_signal(signal.SIGKILL)
        sim.process.wait(timeout=10)
        killed = time.monotonic()
        assert wait_for(lambda: reader.status.state == LidarState.LOST, 3.0)
        assert time.monotonic() - killed < 3.0
        # What the missions are handed is no longer the last scan, once it is stale.
        assert wait_for(lambda: not reader.readings().beams, 3.0)
        started = time.monotonic()
        reader.close()
        assert time.monotonic() - started < 3.0
    finally:
        threading.excepthook = before
    assert not crashes
    assert any("lost" in note for note in notes)


def test_a_protection_stop_is_reported(lidar_sim, readers):
    sim = lidar_sim("--floorplan", str(TWO_ROOMS), "--lidar-health", "error")
    reader = readers(sim.lidar)
    assert wait_for(lambda: reader.status.state == LidarState.UNHEALTHY, 10.0), reader.status
    assert reader.status.health == Health.ERROR and reader.status.error_code != 0
    assert reader.latest() is None and not reader.readings().beams


def test_a_reader_that_falls_behind_marks_the_revolutions_it_lost_samples_of(lidar_sim, readers):
    # A listener holding the reader's thread for a second, as a starved process would:
    # more than MAX_BUFFERED samples pile up and the reader drops them, whole samples at
    # a time, so the line stays in step but the revolution under way has a gap.
    sim = lidar_sim("--floorplan", str(TWO_ROOMS))
    reader = readers(sim.lidar)
    heard: list[LidarScan] = []

    def listen(scan: LidarScan) -> None:
        heard.append(scan)
        if len(heard) == 3:
            time.sleep(1.0)

    reader.subscribe(listen)
    assert wait_for(lambda: len(heard) >= 10, 15.0), reader.status
    before, after = heard[:3], heard[3:]
    assert all(scan.whole and scan.samples == 360 for scan in before)
    assert [scan for scan in after if not scan.whole], [s.samples for s in after]
    # Whole again once it keeps up.
    assert after[-1].whole and after[-1].samples == 360
