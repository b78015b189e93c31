"""The pose estimate kept on disk as the robot drives, for a console or daemon that
starts again after a crash (issue 25, item 0).

A daemon killed mid-`go` and restarted, as systemd's `Restart=on-failure` does, used to
take the robot to be on its dock: a scheduled patrol then drove 99.5 m blind from
there. Now the last estimate is kept, with its uncertainty, and read back at start. It
says where the robot was believed to be, not where it is: the robot ran on after the
last write (up to the runaway bound, design.md's 0.3 m), someone may have pushed it, and
the estimate itself was only an estimate. So it is placed as an assumption
(PoseBasis.ASSUMED), its uncertainty grown by what the robot can have moved since, and
nothing drives on it until a marker confirms it (missions/path_mission.py). It is still
worth keeping: it says which markers to turn to first.

Written from a thread of its own, never the control loop's: at most every WRITE_EVERY_S,
and only when the estimate has changed by more than a little, so a robot at rest does
not write. Each write goes to a new file renamed over the old, owner-only, so that a
crash mid-write leaves the last whole one.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from giraff_console.private_files import PRIVATE_FILE, private_folder
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.loop_events import LoopEvent
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import RUNAWAY_M
from giraff_console.robot.telemetry import Telemetry

# How often the pose may be written while it changes: at 0.4 m/s, 0.2 m between writes,
# which the uncertainty read back allows for (MISSED_M).
WRITE_EVERY_S = 0.5
# Changes smaller than these are not worth a write.
MOVED_M = 0.01
TURNED_RAD = math.radians(0.5)
# What the robot may have done since the last write, as one standard deviation each
# way: the run-on after a crash (the runaway bound), plus a write interval's travel.
MISSED_M = RUNAWAY_M + 0.2
MISSED_HEADING = math.radians(20.0)
# A file longer than this is not ours.
MAX_BYTES = 4096
FORMAT = 1


@dataclass(frozen=True)
class KeptPose:
    """A pose read back: where the robot was believed to be, and how well."""

    pose: Pose
    covariance: np.ndarray  # 3x3, (x, y, heading)
    basis: PoseBasis  # who had said so when it was written

    def as_assumed(self) -> np.ndarray:
        """The covariance to place it with: grown by what may have happened since."""
        grown = np.array(self.covariance, dtype=float)
        grown += np.diag([MISSED_M**2, MISSED_M**2, MISSED_HEADING**2])
        return grown


class PoseKeeperError(Exception):
    """A kept pose that cannot be read: the message says why."""


def read_kept(path: Path, plan: Path) -> KeptPose | None:
    """The pose kept at `path` for the floor plan `plan`; None if there is none, or it
    was kept for another plan (its map frame is another's). PoseKeeperError for a file
    that is there but cannot be read as one."""
    try:
        # Not blocking: a FIFO put in its place would wait for a writer for ever.
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        return None
    except OSError as error:
        raise PoseKeeperError(f"{path}: {error.strerror or error}") from None
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise PoseKeeperError(f"{path}: not a regular file")
        data = os.read(descriptor, MAX_BYTES + 1)
    except OSError as error:
        raise PoseKeeperError(f"{path}: {error.strerror or error}") from None
    finally:
        os.close(descriptor)
    if len(data) > MAX_BYTES:
        raise PoseKeeperError(f"{path}: longer than {MAX_BYTES} bytes: not a kept pose")
    try:
        kept = json.loads(data)
        if kept["format"] != FORMAT:
            raise PoseKeeperError(f"{path}: format {kept['format']!r}, not {FORMAT}")
        if kept["plan"] != str(plan):
            return None
        x, y, heading = (float(v) for v in kept["pose"])
        covariance = np.array(kept["covariance"], dtype=float)
        basis = PoseBasis(kept["basis"])
    except PoseKeeperError:
        raise
    except (ValueError, KeyError, TypeError) as error:
        raise PoseKeeperError(f"{path}: not a kept pose ({error})") from None
    finite = all(map(math.isfinite, (x, y, heading))) and np.isfinite(covariance).all()
    if covariance.shape != (3, 3) or not finite:
        raise PoseKeeperError(f"{path}: not a kept pose (a 3x3 covariance of finite numbers)")
    return KeptPose(Pose(x, y, heading), covariance, basis)


class PoseKeeper:
    """Keeps the loop's estimate in `path`, for the floor plan `plan`; see the module
    docstring. `hear` is the loop's listener; `close` writes the last and stops."""

    def __init__(self, path: Path, plan: Path) -> None:
        self.path = Path(path)
        self.plan = str(plan)
        self.problem: str | None = None  # the first write that failed
        self._latest: Estimate | None = None
        self._written: Estimate | None = None
        self._changed = threading.Condition()
        self._closing = False
        self._thread = threading.Thread(target=self._write_on, name="pose-keeper", daemon=True)
        self._thread.start()

    def hear(self, event: LoopEvent) -> None:
        """On the loop's thread: only takes note; the writing is the keeper's thread's."""
        if isinstance(event, Telemetry) and event.estimate is not None:
            with self._changed:
                self._latest = event.estimate
                self._changed.notify()

    def close(self, timeout: float = 1.0) -> None:
        """Write the last estimate, if it changed, and stop."""
        with self._changed:
            self._closing = True
            self._changed.notify()
        self._thread.join(timeout)

    def _write_on(self) -> None:
        while True:
            with self._changed:
                self._changed.wait_for(lambda: self._closing or self._worth_writing())
                estimate, closing = self._latest, self._closing
            if estimate is not None and self._worth_writing():
                self._write(estimate)
            if closing:
                return
            with self._changed:  # no sooner than WRITE_EVERY_S after the last
                self._changed.wait_for(lambda: self._closing, timeout=WRITE_EVERY_S)

    def _worth_writing(self) -> bool:
        latest, written = self._latest, self._written
        if latest is None:
            return False
        if written is None:
            return True
        moved = math.dist((latest.pose.x, latest.pose.y), (written.pose.x, written.pose.y))
        turned = abs(math.remainder(latest.pose.heading - written.pose.heading, math.tau))
        return moved > MOVED_M or turned > TURNED_RAD or latest.basis is not written.basis

    def _write(self, estimate: Estimate) -> None:
        pose = estimate.pose
        text = json.dumps({
            "format": FORMAT, "plan": self.plan,
            "pose": [pose.x, pose.y, pose.heading],
            "covariance": [list(row) for row in estimate.covariance],
            "basis": estimate.basis.value,
        })  # fmt: skip
        temporary = self.path.with_name(f".{self.path.name}.{os.getpid()}")
        try:
            private_folder(self.path.parent)
            descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, PRIVATE_FILE)
            try:
                os.write(descriptor, text.encode())
                os.fsync(descriptor)  # a power cut keeps the last whole pose
            finally:
                os.close(descriptor)
            os.replace(temporary, self.path)
            self._written = estimate
        except OSError as error:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
            if self.problem is None:
                self.problem = f"cannot keep the pose in {self.path}: {error.strerror or error}"
