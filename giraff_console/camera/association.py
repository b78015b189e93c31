"""Which odometry sample goes with which frame (§3.3.1).

The original read the odometry right after each frame, in the same thread, to keep the
two associated. Here the camera and the control loop run apart, so the poses the loop
publishes are kept, briefly, with their times, and each frame takes the nearest one.
"""

from __future__ import annotations

import bisect
import collections
import threading

Sample = tuple[float, float, float]  # x, y, heading

# Two seconds of samples at 20 Hz: far more than a frame waits for its encoder.
KEEP = 40


class SampleHistory:
    """Timestamped odometry samples; thread-safe, since producer and reader differ."""

    def __init__(self, keep: int = KEEP) -> None:
        self._lock = threading.Lock()
        self._times: collections.deque[float] = collections.deque(maxlen=keep)
        self._samples: collections.deque[Sample] = collections.deque(maxlen=keep)

    def add(self, time: float, sample: Sample) -> None:
        with self._lock:
            self._times.append(time)
            self._samples.append(sample)

    def nearest(self, time: float) -> Sample | None:
        """The sample taken closest to `time`, or None before the first one."""
        with self._lock:
            if not self._times:
                return None
            times = list(self._times)
            index = bisect.bisect_left(times, time)
            candidates = [i for i in (index - 1, index) if 0 <= i < len(times)]
            best = min(candidates, key=lambda i: abs(times[i] - time))
            return self._samples[best]
