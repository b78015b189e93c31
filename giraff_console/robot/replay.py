"""Interpreting a played-back session as the live console interprets the board.

The recorded replies go to the control loop's listeners as live exchanges do (the
transcript), and the recorded `bulk_data` replies to an odometry of their own, so that
the pose on screen is the pose that was seen when recording (§3.2.1.1). The live
odometry is left alone, and carries on when playback ends. The recorded reads are taken
as the live console took them (`RecordedReads`): with the wheel reading and the wheel
base the session started with, every read of bulk_data for a board whose reads reset
imdl/imdr, and the encoders' counts that followed the poll when they were the reading.

A session recorded with the pose filter (issue 14) also has its estimates, written a
few times a second (recording/estimates.py). Between two, the live filter only carried
its pose along by what the wheels did; playback does the same with the odometry it
integrates again, so that the pose shown moves at every poll and sits, at each recorded
estimate, exactly where that one says. Its covariance is the latest recorded. The pose
shown during such a playback is the estimate's, as it was live.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

from giraff_console.link.exchange import Exchange
from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.errors import ProtocolError
from giraff_console.recording.control_log import LogEntry, LogRead
from giraff_console.recording.estimates import RecordedEstimate
from giraff_console.recording.playback import Playback, as_exchange
from giraff_console.recording.session import PoseSample, SessionStart
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.wheel_odometers import Reading

# A minute of automatic polls at 20 Hz.
CHECKPOINT_ENTRIES = 1200


@dataclass(frozen=True)
class PlaybackStatus:
    """What the console shows about a playback."""

    name: str
    position: float
    duration: float
    speed: float
    paused: bool


class Replayer:
    """A playback and the pose, motor state and estimate it implies.

    The pose after a seek is integrated again from the nearest point already passed, not
    from the start, so that seeking in an hour-long session stays quick: a checkpoint of
    the odometry is kept every CHECKPOINT_ENTRIES entries.
    """

    def __init__(self, playback: Playback) -> None:
        self.playback = playback
        self.odometry = starting_odometry(playback.start)
        self.reads = RecordedReads(self.odometry.reading)
        self.state: MotorState | None = None
        self._done = 0  # entries interpreted so far
        # Recorded estimates taken in so far, and where the odometry stood when the last
        # of them was taken in: what it has done since carries that estimate along.
        self._estimates = 0
        self._anchor: Pose | None = None
        # The console's clock minus the playback position, as of the last advance or
        # seek: to put a recorded correction's time on the console's clock.
        self._clock_offset = 0.0
        # Entries interpreted -> (pose, odometry reference, state, a poll waiting for its
        # encoders, estimates taken in, anchor) at that point.
        self._checkpoints: dict[int, _Checkpoint] = {0: self._checkpoint()}

    def advance(self, now: float, notify: Callable[[Exchange], None]) -> None:
        """Hand out what has fallen due, and take the odometry along."""
        for entry in self.playback.due(now):
            exchange = as_exchange(entry, now)
            notify(exchange)
            self._interpret(entry)
        # The same grace as Playback.due's: what is handed out and what is taken in agree.
        self._take_estimates(self._position(now) + 1e-6)

    def seek(self, now: float, offset: float) -> None:
        """Move to `offset`, the pose and the estimate with it."""
        target = self.playback.seek(now, offset)
        start = max(index for index in self._checkpoints if index <= target)
        checkpoint = self._checkpoints[start]
        pose, reference, self.state, self.reads.pending = checkpoint[:4]
        self._estimates, self._anchor = checkpoint[4:]
        self.odometry.reset(pose, reference)
        self._done = start
        for entry in self.playback.entries[start:target]:
            self._interpret(entry)
        self._take_estimates(self._position(now))

    def status(self, now: float) -> PlaybackStatus:
        playback = self.playback
        return PlaybackStatus(playback.name, min(playback.position(now), playback.duration),
                              playback.duration, playback.speed, playback.paused)  # fmt: skip

    @property
    def pose(self) -> Pose:
        """The recorded estimate's pose if the session has one by now, as the console
        showed it live; else the odometry's."""
        estimate = self.estimate
        return self.odometry.pose if estimate is None else estimate.pose

    @property
    def estimate(self) -> Estimate | None:
        """The pose filter's estimate at the playback position, as recorded and carried
        along by the odometry since (see the module docstring); None for a session
        recorded without, or before its first estimate."""
        if self._estimates == 0 or self._anchor is None:
            return None
        recorded = self.playback.estimates[self._estimates - 1]
        now = self.odometry.pose
        corrected = recorded.corrected_at
        return Estimate(
            pose=carried(Pose(*recorded.pose), self._anchor, now),
            odometry=carried(Pose(*recorded.odometry), self._anchor, now),
            covariance=recorded.covariance,
            sigma_m=recorded.sigma_m,
            sigma_heading=recorded.sigma_heading,
            ellipse=recorded.ellipse,
            landmarks=recorded.landmarks,
            found=recorded.found,
            seen=recorded.seen,
            rejected=recorded.rejected,
            corrected_at=None if corrected is None else corrected + self._clock_offset,
        )

    def _position(self, now: float) -> float:
        position = self.playback.position(now)
        self._clock_offset = now - position
        return position

    def _take_estimates(self, until: float) -> None:
        """Take in the recorded estimates up to `until` seconds into the session."""
        estimates = self.playback.estimates
        taken = bisect.bisect_right(estimates, until, lo=self._estimates,
                                    key=lambda estimate: estimate.offset)  # fmt: skip
        if taken > self._estimates:
            self._estimates, self._anchor = taken, self.odometry.pose

    def _checkpoint(self) -> _Checkpoint:
        odometry = self.odometry
        return (odometry.pose, odometry.reference, self.state, self.reads.pending,
                self._estimates, self._anchor)  # fmt: skip

    def _interpret(self, entry: LogEntry) -> None:
        # An estimate was published after the polls up to its time, before later ones.
        self._take_estimates(math.nextafter(entry.offset, -math.inf))
        self._done += 1
        state = self.reads.take(entry)
        if state is not None:
            try:
                self.odometry.update(state)
                self.state = state
            except ProtocolError:
                pass  # a board without wheel distances: the pose cannot follow
        if self._done % CHECKPOINT_ENTRIES == 0:
            self._checkpoints[self._done] = self._checkpoint()


_Checkpoint = tuple[Pose, MotorState | None, MotorState | None, MotorState | None, int, Pose | None]


def carried(pose: Pose, since: Pose, now: Pose) -> Pose:
    """`pose` moved as the odometry moved from `since` to `now`: the same step, taken in
    the robot's own frame, which is how the filter predicts between corrections."""
    dx, dy = now.x - since.x, now.y - since.y
    cos_s, sin_s = math.cos(since.heading), math.sin(since.heading)
    ahead, left = cos_s * dx + sin_s * dy, -sin_s * dx + cos_s * dy
    cos_p, sin_p = math.cos(pose.heading), math.sin(pose.heading)
    return Pose(pose.x + cos_p * ahead - sin_p * left, pose.y + sin_p * ahead + cos_p * left,
                pose.heading + (now.heading - since.heading))  # fmt: skip


def recorded_estimate(estimate: Estimate, offset: float, origin: float) -> RecordedEstimate:
    """`estimate`, published `offset` seconds into a session whose clock starts at
    `origin`, as estimate.jsonl keeps it."""
    corrected = estimate.corrected_at
    return RecordedEstimate(
        offset=offset,
        pose=_triple(estimate.pose),
        odometry=_triple(estimate.odometry),
        covariance=estimate.covariance,  # type: ignore[arg-type]
        sigma_m=estimate.sigma_m,
        sigma_heading=estimate.sigma_heading,
        ellipse=estimate.ellipse,
        landmarks=estimate.landmarks,
        found=estimate.found,
        seen=estimate.seen,
        rejected=estimate.rejected,
        corrected_at=None if corrected is None else corrected - origin,
    )


def _triple(pose: Pose) -> tuple[float, float, float]:
    return pose.x, pose.y, pose.heading


class RecordedReads:
    """The samples a session's log gives the odometry, as the live console took them
    with `reading` (robot/odometry_feed.py)."""

    def __init__(self, reading: Reading) -> None:
        self.reading = reading
        # With the encoders: the poll, and the counts read since, until both are in.
        self.pending: MotorState | None = None

    def take(self, entry: LogEntry) -> MotorState | None:
        """The sample `entry` completes, if any."""
        if self.reading is Reading.ENCODERS:
            return self._encoders(entry)
        if self.reading is Reading.INCREMENTS and entry.param == "bulk_data":
            # A read resets the increments: every one, typed or polled, counted live.
            return recorded_state(entry, polled_only=False)
        return recorded_state(entry)

    def _encoders(self, entry: LogEntry) -> MotorState | None:
        if entry.frame_marker:
            self.pending = recorded_state(entry)
            return None
        pending = self.pending
        if pending is None or not entry.automatic or entry.param not in ("enc0", "enc1"):
            return None
        value = as_exchange(entry, entry.offset).value
        if not isinstance(value, int | float) or not math.isfinite(value):
            self.pending = None  # a count that cannot be read: this poll goes without
            return None
        if entry.param == "enc0":
            self.pending = replace(pending, enc0=round(value))
            return None
        self.pending = None
        return replace(pending, enc1=round(value)) if pending.enc0 is not None else None


def recorded_state(entry: LogEntry, polled_only: bool = True) -> MotorState | None:
    """The motor state an automatic `bulk_data` poll recorded (without `polled_only`, any
    `get bulk_data`); None for anything else.

    It is stamped with the recorded time, not the playback's, so that speed and seeks
    do not change what the odometry's plausibility check sees.
    """
    if entry.param != "bulk_data" or entry.flag not in ("G", " "):
        return None
    if polled_only and not entry.frame_marker:
        # Only the automatic poll feeds the odometry, live as in the original's playback
        # (B.2 PlaybackData); a `get bulk_data` typed by hand is shown, not integrated.
        return None
    value = as_exchange(entry, entry.offset).value
    if not isinstance(value, dict):
        return None
    try:
        return MotorState.from_bulk(value, entry.offset)
    except ProtocolError:
        # A bulk reply without a needed field: shown in the transcript, not used.
        return None


def starting_odometry(start: SessionStart) -> Odometry:
    """An odometry where the live one stood as recording began, reading the wheels as it
    did."""
    odometry = Odometry(wheel_base=start.wheel_base, reading=start.odometers)
    reference = MotorState(cang=0.0, cdis=0.0, gvr=0.0, speed=0.0, cvg=start.cvg, tilt=None,
                           imdl=start.imdl, imdr=start.imdr, mode=0, received_at=start.offset,
                           enc0=start.enc0, enc1=start.enc1)  # fmt: skip
    usable = odometry.odometers.usable(reference)
    odometry.reset(Pose(start.x, start.y, start.heading), reference if usable else None)
    return odometry


def session_start(odometry: Odometry, origin: float) -> SessionStart:
    """Where `odometry` stands, for a session whose clock starts at `origin`: what
    `starting_odometry` needs to carry on from there."""
    pose, reference = odometry.pose, odometry.reference
    start = SessionStart(pose.x, pose.y, pose.heading, odometers=odometry.reading.value,
                         wheel_base=odometry.wheel_base)  # fmt: skip
    if reference is not None and odometry.odometers.usable(reference):
        start = replace(start, imdl=reference.imdl, imdr=reference.imdr, cvg=reference.cvg,
                        enc0=reference.enc0, enc1=reference.enc1,
                        offset=reference.received_at - origin)  # fmt: skip
    return start


def replay_poses(log: LogRead, start: SessionStart | None = None) -> Iterator[PoseSample]:
    """The pose at every sample the live odometry took (`RecordedReads`), as the console
    saw it."""
    odometry = starting_odometry(start or SessionStart())
    reads = RecordedReads(odometry.reading)
    for entry in log.entries:
        state = reads.take(entry)
        if state is None:
            continue
        try:
            pose = odometry.update(state)
        except ProtocolError:
            return
        yield PoseSample(state.received_at, pose.x, pose.y, pose.heading)
