"""What the lidar's tests share: the simulator with its lidar in another process, and a
reader on its pty that is always closed."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from giraff_console.lidar.device import open_named
from giraff_console.lidar.reader import LidarReader, LidarState
from tests.conftest import CHILD_TIMEOUT, kill_process, stop_sim_process

# Two rooms and a 0.8 m door; the robot starts at (1, 1) facing +x (see the file).
TWO_ROOMS = Path(__file__).parent / "two_rooms.yaml"


class LidarSim:
    """`giraff-console sim --pty --lidar` in another process: the board's pty and the
    lidar's, from the first two lines of its output."""

    def __init__(self, *args: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "sim", "--pty", "--lidar", *args],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
        )  # fmt: skip
        try:
            self.board, self.lidar = _lines(self.process, 2)
        except BaseException:
            kill_process(self.process)
            raise

    def stop(self) -> None:
        if self.process.poll() is None:
            stop_sim_process(self.process)


def _lines(process: subprocess.Popen, count: int) -> list[str]:
    assert process.stdout is not None
    fd, output = process.stdout.fileno(), b""
    deadline = time.monotonic() + CHILD_TIMEOUT
    while output.count(b"\n") < count:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"no {count} lines from the simulator: {output!r}"
        if select.select([fd], [], [], remaining)[0]:
            chunk = os.read(fd, 4096)
            assert chunk, f"the simulator ended early: {output!r}"
            output += chunk
    return [line.strip() for line in output.decode().split("\n")[:count]]


@pytest.fixture
def lidar_sim() -> Iterator[Callable[..., LidarSim]]:
    started: list[LidarSim] = []

    def start(*args: str) -> LidarSim:
        sim = LidarSim(*args)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.stop()


@pytest.fixture
def readers() -> Iterator[Callable[..., LidarReader]]:
    """Readers on a port, started; closed after the test."""
    made: list[LidarReader] = []

    def reader(path: str, **kwargs) -> LidarReader:
        made.append(LidarReader(kwargs.pop("opener", None) or open_named(path, 115200, 0.5),
                                path, **kwargs))  # fmt: skip
        made[-1].start()
        return made[-1]

    yield reader
    for reader in made:
        reader.close()


def wait_for(what: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
    """Whether `what` came true within `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if what():
            return True
        time.sleep(step)
    return what()


def scanning(reader: LidarReader) -> bool:
    return reader.status.state == LidarState.SCANNING and reader.latest() is not None
