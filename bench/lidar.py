"""Benchmark: what reading an RPLIDAR costs the console (issue 29, item 1).

The simulated RPLIDAR runs in another process (`giraff-console sim --pty --lidar`), at
an A1's 5.5 revolutions a second of 360 samples and an A2's 10 of 400; this process
reads its pty for SECONDS and measures its own CPU (process time over wall time, % of
one core) for three readers of the same bytes:

- reader: the console's LidarReader (lidar/reader.py): the package's normal-scan
  samples assembled into revolutions in the robot's frame, the latest kept;
- bare package: adafruit_rplidar's own `iter_measurements` loop, each sample decoded
  and dropped, no assembly (the peer: what the package costs by itself);
- raw bytes: the pty read in 4 KiB chunks, nothing decoded (the floor);
- reader + mapping: the reader, and every revolution laid into a map as `map` does
  (missions/mapping.py: the pose trail, the map builder with its scan matcher), the
  robot standing in the simulator's building (issue 29: "mapping keeps up with the
  sensor ... using <= 20 % of a core").

Each line also gives the samples a second that reached the reader, to show it kept up.

Usage: python bench/lidar.py [--seconds 6]
"""

from __future__ import annotations

import argparse
import os
import select
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from adafruit_rplidar import SCAN_TYPE_NORMAL

from giraff_console.lidar.device import RplidarDevice, open_named
from giraff_console.lidar.reader import LidarReader
from giraff_console.missions.mapping import MappingRun
from giraff_console.planning.map_building import MapBuilder
from giraff_console.robot.odometry import Pose

PLAN = Path(__file__).resolve().parent.parent / "tests" / "lidar" / "two_rooms.yaml"
CONFIGS = ((5.5, 360), (10.0, 400))


def start_sim(rate: float, samples: int) -> tuple[subprocess.Popen, str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", "--lidar", "--floorplan",
         str(PLAN), "--lidar-rate", str(rate), "--lidar-samples", str(samples)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
    )  # fmt: skip
    assert process.stdout is not None
    output = b""
    deadline = time.monotonic() + 20
    while output.count(b"\n") < 2:
        if time.monotonic() > deadline:
            process.kill()
            raise SystemExit("the simulator printed no lidar pty")
        if select.select([process.stdout], [], [], 1.0)[0]:
            output += os.read(process.stdout.fileno(), 4096)
    return process, output.decode().split("\n")[1].strip()


def measured(run: Callable[[float], int], seconds: float) -> tuple[float, float]:
    """(% of a core, samples a second) over `seconds` of `run`."""
    wall, cpu = time.monotonic(), time.process_time()
    samples = run(seconds)
    wall, cpu = time.monotonic() - wall, time.process_time() - cpu
    return 100 * cpu / wall, samples / wall


def by_reader(path: str) -> Callable[[float], int]:
    def run(seconds: float) -> int:
        counted = [0]
        reader = LidarReader(open_named(path, 115200, 1.0), path)
        reader.subscribe(lambda scan: counted.__setitem__(0, counted[0] + scan.samples))
        reader.start()
        time.sleep(seconds)
        reader.close()
        return counted[0]

    return run


def by_reader_mapping(path: str) -> Callable[[float], int]:
    def run(seconds: float) -> int:
        laid = [0]
        reader = LidarReader(open_named(path, 115200, 1.0), path)
        mapping = MappingRun(MapBuilder(), lambda text: None, Pose(0.0, 0.0, 0.0),
                             after=lambda run: laid.__setitem__(0, run.status().scans))  # fmt: skip
        reader.subscribe(mapping.scan)
        reader.start()
        end = time.monotonic() + seconds
        while time.monotonic() < end:  # the loop's poses at 20 Hz: standing still
            mapping.pose(time.monotonic(), Pose(0.0, 0.0, 0.0), 0.01)
            time.sleep(0.05)
        reader.close()
        mapping.close()
        return laid[0] * samples_of(path)

    return run


def samples_of(path: str) -> int:
    return SAMPLES_BY_PATH.get(path, 0)


SAMPLES_BY_PATH: dict[str, int] = {}


def by_bare_package(path: str) -> Callable[[float], int]:
    def run(seconds: float) -> int:
        device = RplidarDevice(open_named(path, 115200, 1.0), path, 115200, 1.0)
        device.start(SCAN_TYPE_NORMAL)
        count, end = 0, time.monotonic() + seconds
        for _ in device.iter_measurements(720):
            count += 1
            if count % 100 == 0 and time.monotonic() > end:
                break
        device.stop()
        device.disconnect()
        return count

    return run


def by_raw_bytes(path: str) -> Callable[[float], int]:
    def run(seconds: float) -> int:
        device = RplidarDevice(open_named(path, 115200, 1.0), path, 115200, 1.0)
        device.start(SCAN_TYPE_NORMAL)
        port = device._port()
        count, end = 0, time.monotonic() + seconds
        while time.monotonic() < end:
            count += len(port.read(max(1, min(4096, port.in_waiting))))
        device.stop()
        device.disconnect()
        return count // 5

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=6.0)
    args = parser.parse_args()
    print(f"{'sensor':<16}{'reader':<18}{'% of a core':>12}{'samples/s':>11}")
    for rate, samples in CONFIGS:
        process, path = start_sim(rate, samples)
        SAMPLES_BY_PATH[path] = samples
        try:
            for name, make in (("reader", by_reader), ("bare package", by_bare_package),
                               ("raw bytes", by_raw_bytes),
                               ("reader + mapping", by_reader_mapping)):  # fmt: skip
                time.sleep(0.3)  # the sensor quiet again after the last reader's STOP
                core, rate_seen = measured(make(path), args.seconds)
                print(f"{f'{rate:g} Hz x {samples}':<16}{name:<18}{core:>11.1f}%"
                      f"{rate_seen:>11.0f}")  # fmt: skip
        finally:
            process.terminate()
            process.wait(timeout=20)


if __name__ == "__main__":
    main()
