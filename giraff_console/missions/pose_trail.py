"""Where the robot was believed to be a moment ago: the pose filter's poses of the last
seconds, for a reading taken between two ticks.

A range sensor's revolution is stamped when it ends, on its own thread; the control
loop estimates the pose 20 times a second on its. At 1 rad/s a pose 50 ms off turns
a wall 5 m away by 25 cm, so a scan is placed at the pose interpolated to its stamp,
never at whatever pose is latest (thesis §2.3: the pose comes from odometry, tick by
tick).
"""

from __future__ import annotations

import bisect
import collections
import math
import threading

from giraff_console.robot.odometry import Pose

# How far back the trail reaches: a scan older than this is too late to place.
TRAIL_S = 3.0
# A range sensor's revolution is stamped with its last sample's time, its samples taken
# over the turn before: an RPLIDAR A1/A2 turns 5.5 times a second (the datasheets'
# typical rate).
REVOLUTION_S = 1 / 5.5
# A revolution taken while the robot turns faster than this is smeared: the sensor
# sweeps for a fifth of a second, and a turn on the spot at teleop's 45 degrees a second
# smears it by 8 degrees (a wall 5 m off by 0.7 m).
MAX_TURN_RATE = math.radians(15.0)
# Over this much time before a revolution's end the turn rate is taken.
TURN_RATE_S = 0.2
# The most poses it holds (a 20 Hz loop fills 60 in TRAIL_S; a stepped one may tick
# faster), so that it is bounded whatever the clock does.
MAX_POSES = 1000


class PoseTrail:
    """The (time, pose) of the latest ticks; safe to add to on one thread and read on
    another."""

    def __init__(self, seconds: float = TRAIL_S) -> None:
        self.seconds = seconds
        self._times: collections.deque[float] = collections.deque(maxlen=MAX_POSES)
        self._poses: collections.deque[Pose] = collections.deque(maxlen=MAX_POSES)
        self._sigmas: collections.deque[float] = collections.deque(maxlen=MAX_POSES)
        self._lock = threading.Lock()

    def add(self, time: float, pose: Pose, heading_sigma: float = 0.0) -> None:
        """The pose at `time`, no earlier than the last one added, and how well the
        filter knew its heading (a standard deviation, radians)."""
        with self._lock:
            if self._times and time < self._times[-1]:
                return  # a clock that went back: the trail keeps its order
            self._times.append(time)
            self._poses.append(pose)
            self._sigmas.append(heading_sigma)
            while self._times and self._times[0] < time - self.seconds:
                self._times.popleft()
                self._poses.popleft()
                self._sigmas.popleft()

    def heading_sigma(self, time: float) -> float:
        """How well the filter knew the heading at the last tick before `time` (0 with
        no tick before it)."""
        with self._lock:
            times, sigmas = list(self._times), list(self._sigmas)
        index = bisect.bisect_right(times, time)
        return sigmas[index - 1] if index else 0.0

    def at(self, time: float) -> Pose | None:
        """The pose at `time`, between the two ticks either side of it; the latest if
        `time` is after it by less than a tick's worth of the trail; None if `time` is
        outside the trail (too old, or nothing yet)."""
        with self._lock:
            times, poses = list(self._times), list(self._poses)
        if not times or time < times[0]:
            return None
        index = bisect.bisect_right(times, time)
        if index == len(times):
            # After the last tick: the scan ended between it and the next one.
            gap = times[-1] - times[-2] if len(times) > 1 else 0.0
            return poses[-1] if time - times[-1] <= max(gap, 0.1) else None
        before, after = poses[index - 1], poses[index]
        span = times[index] - times[index - 1]
        share = (time - times[index - 1]) / span if span > 0 else 1.0
        turn = math.remainder(after.heading - before.heading, math.tau)
        return Pose(
            before.x + share * (after.x - before.x),
            before.y + share * (after.y - before.y),
            before.heading + share * turn,
        )

    def turning(self, time: float) -> bool:
        """Whether the robot turned faster than MAX_TURN_RATE over the TURN_RATE_S before
        `time`: a revolution that ended then is smeared (False where the trail does not
        reach that far back)."""
        after, before = self.at(time), self.at(time - TURN_RATE_S)
        if after is None or before is None:
            return False
        turned = abs(math.remainder(after.heading - before.heading, math.tau))
        return turned > MAX_TURN_RATE * TURN_RATE_S
