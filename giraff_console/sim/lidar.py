"""A simulated Slamtec RPLIDAR A1 (or A2): the bytes it answers, and what it sees.

The thesis would add a laser range finder (§6); this is one, on the robot's centre and
facing its front, speaking the RPLIDAR serial protocol (protocol/rplidar.py) so that
the console's reading code (lidar/) drives it as it would drive the real sensor.

Answered as an A1 answers: GET_INFO (model 0x18, firmware 1.29, hardware 7), GET_HEALTH
(good, unless told otherwise), SCAN and FORCE_SCAN (a stream of 5-byte samples, `rate`
revolutions a second of `samples` each), STOP, RESET, SET_MOTOR_PWM (accepted and
ignored: an A1's motor follows the DTR line, which a pseudo-terminal does not carry, so
the simulated motor always turns). Not supported: express and extended scans (0x82,
0x84), GET_SAMPLERATE (0x59), GET_LIDAR_CONF (0x84) and accessory-board commands (an A1
ignores what it does not know, and so does this); RESET's text banner is not sent (the
reading code flushes its input after a reset anyway).

Its world: the building's walls and the `Surroundings` (boxes, closed doors), ray-cast
from the simulator's true pose, which the wire never shows. Real A1 figures: about
5.5 revolutions a second, 360 samples each, 0.15 to 12 m; the datasheet's accuracy is
about 1 % of the range below 3 m, 2 % to 5 m and 2.5 % beyond, which `noise` adds
(seeded) as a standard deviation.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from giraff_console.protocol.rplidar import (
    Command,
    Health,
    encode_samples,
    health_reply,
    info_reply,
    parse_requests,
    scan_descriptor,
)
from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import Surroundings, cast_rays

A1_RATE_HZ = 5.5
A1_SAMPLES = 360
A1_RANGE_M = (0.15, 12.0)
# Rates and sample counts a spinning RPLIDAR can have (the A2 reaches 10 Hz, the A3
# 20 Hz; an A1 gives about 2000 samples a second, an A3 16000).
RATE_LIMITS_HZ = (1.0, 20.0)
SAMPLE_LIMITS = (16, 4000)
# Samples cast together: an eighth of a turn at the A1's figures, so that a moving robot
# smears its scan as a real one does, without casting every sample on its own.
CHUNK = 45
# What a good return's quality byte says (6 bits); a missed one says 0.
HIT_QUALITY = 47
# Samples held for a host that does not read: two revolutions, then the oldest go, as
# a real sensor's stream simply runs past a host that is not listening.
BACKLOG_REVOLUTIONS = 2
SERIAL_NUMBER = bytes(range(0x10, 0x20))

Segment = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class LidarConfig:
    """How the simulated sensor spins and what it says of itself."""

    rate_hz: float = A1_RATE_HZ
    samples: int = A1_SAMPLES
    noise: bool = False
    seed: int | None = None
    health: Health = Health.GOOD

    def __post_init__(self) -> None:
        low, high = RATE_LIMITS_HZ
        if not low <= self.rate_hz <= high:
            raise ValueError(f"a lidar turns {low:g} to {high:g} times a second")
        low_n, high_n = SAMPLE_LIMITS
        if not low_n <= self.samples <= high_n:
            raise ValueError(f"a lidar takes {low_n} to {high_n} samples a revolution")


class LidarWorld:
    """What the sensor sees: fixed walls and the surroundings, from the true pose."""

    def __init__(self, pose: Callable[[], TruePose], walls: Sequence[Segment],
                 surroundings: Surroundings | None = None) -> None:  # fmt: skip
        self.pose = pose
        self.surroundings = surroundings
        wall_array = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
        self._wall_starts, self._wall_ends = wall_array[:, 0], wall_array[:, 1]

    def distances(self, bearings: np.ndarray) -> np.ndarray:
        """The nearest hit along each bearing (robot frame, radians, positive left) from
        where the robot truly stands; inf where nothing is met."""
        pose = self.pose()
        starts, ends = self._wall_starts, self._wall_ends
        if self.surroundings is not None:
            more_starts, more_ends = self.surroundings.segments()
            if len(more_starts):
                starts = np.concatenate([starts, more_starts])
                ends = np.concatenate([ends, more_ends])
        if not len(starts):
            return np.full(len(bearings), np.inf)
        angle = pose.heading + bearings
        t, _ = cast_rays(pose.x, pose.y, np.cos(angle), np.sin(angle), starts, ends)
        return t.min(axis=1)


class SimLidar:
    """The sensor's side of the line: requests in, answers and samples out, by time."""

    def __init__(self, world: LidarWorld | None, config: LidarConfig = LidarConfig()) -> None:
        self.world = world
        self.config = config
        self._rng = np.random.default_rng(config.seed)
        self._requests = bytearray()
        self._out = bytearray()
        self._scan_since: float | None = None
        self._sent = 0  # samples sent since the scan started
        self.motor_pwm = 0
        interval = 1.0 / (config.rate_hz * config.samples)
        self._interval = interval
        # The sensor's angle of each sample of a revolution, clockwise from its front.
        self._angles = np.arange(config.samples) * (360.0 / config.samples)

    @property
    def scanning(self) -> bool:
        return self._scan_since is not None

    def receive(self, data: bytes, now: float) -> None:
        """Bytes from the host; every whole request is acted on at `now`."""
        self._requests += data
        for asked in parse_requests(self._requests):
            self._obey(asked.command, asked.payload, now)

    def pop_due(self, now: float) -> bytes:
        """What the sensor has sent by `now`: answers, and the samples measured since."""
        if self._scan_since is not None:
            due = int((now - self._scan_since) / self._interval) + 1
            backlog = BACKLOG_REVOLUTIONS * self.config.samples
            if due - self._sent > backlog:
                self._sent = due - backlog
            while self._sent < due:
                count = min(CHUNK, due - self._sent)
                self._out += self._samples(self._sent, count)
                self._sent += count
        out = bytes(self._out)
        self._out.clear()
        return out

    def next_due(self) -> float | None:
        """When the next sample is measured; None while not scanning."""
        if self._scan_since is None:
            return None
        return self._scan_since + self._sent * self._interval

    def hang_up(self) -> None:
        """The host went away: a real sensor keeps spinning, but nobody reads it; it
        stops scanning so that a new host starts from a quiet line."""
        self._requests.clear()
        self._out.clear()
        self._scan_since = None

    def _obey(self, command: int, payload: bytes, now: float) -> None:
        if command == Command.STOP:
            self._scan_since = None
        elif command == Command.RESET:
            self._scan_since = None
            self._out.clear()
        elif command in (Command.SCAN, Command.FORCE_SCAN):
            if self.config.health == Health.ERROR:
                return  # in protection stop the sensor does not scan until reset
            if self._scan_since is None:
                self._out += scan_descriptor()
                self._scan_since, self._sent = now, 0
        elif command == Command.GET_INFO and self._scan_since is None:
            self._out += info_reply(0x18, (1, 29), 7, SERIAL_NUMBER)
        elif command == Command.GET_HEALTH and self._scan_since is None:
            code = 0 if self.config.health == Health.GOOD else 0x8001
            self._out += health_reply(self.config.health, code)
        elif command == Command.SET_MOTOR_PWM and len(payload) == 2:
            self.motor_pwm = int.from_bytes(payload, "little")

    def _samples(self, first: int, count: int) -> bytes:
        """`count` samples from the `first` of the scan, cast from the pose of now."""
        n = self.config.samples
        index = (first + np.arange(count)) % n
        angles = self._angles[index]
        # The sensor's angles grow clockwise; the robot's bearings counter-clockwise.
        bearings = -np.radians(angles)
        if self.world is not None:
            distance = self.world.distances(bearings)
        else:
            distance = np.full(count, np.inf)
        if self.config.noise:
            distance = distance + self._rng.standard_normal(count) * _accuracy(distance)
        low, high = A1_RANGE_M
        seen = np.isfinite(distance) & (distance >= low) & (distance <= high)
        distance_mm = np.where(seen, distance * 1000.0, 0.0)
        quality = np.where(seen, HIT_QUALITY, 0)
        return encode_samples(angles, distance_mm, quality, index == 0)


def _accuracy(distance: np.ndarray) -> np.ndarray:
    """The datasheet's accuracy at each distance, in metres (A1: 1 % of the range below
    3 m, 2 % from 3 to 5 m, 2.5 % beyond); 0 where nothing was met."""
    finite = np.where(np.isfinite(distance), distance, 0.0)
    share = np.where(finite < 3.0, 0.01, np.where(finite <= 5.0, 0.02, 0.025))
    return share * finite
