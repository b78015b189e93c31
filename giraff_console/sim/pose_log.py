"""A log of the simulated robot's true pose, for measuring from outside the process.

The wire never shows the true pose; tests and benchmarks that drive the simulator in
another process read this file instead, for example to measure how far the robot ran
on after a console was killed.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path

from giraff_console.sim.board import GiraffBoard

PERIOD_S = 0.02


class PoseLog:
    """Writes `time x y heading_deg moving` lines, flushed, every 20 ms."""

    def __init__(self, board: GiraffBoard, path: Path) -> None:
        self.board = board
        self._file = path.open("w", buffering=1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pose-log", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(PERIOD_S):
            pose = self.board.true_pose
            moving = self.board.drive.mode_bits() & 0x80
            self._file.write(
                f"{self.board.clock.now():.4f} {pose.x:.5f} {pose.y:.5f} "
                f"{math.degrees(pose.heading):.3f} {1 if moving else 0}\n"
            )

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self._file.close()
