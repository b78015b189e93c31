"""Interpreting a played-back session as the live console interprets the board.

The recorded replies go to the same observers as live exchanges (the transcript) and
the recorded `bulk_data` replies to an odometry of their own, so that the pose on screen
is the pose that was seen when recording (§3.2.1.1). The live odometry is left alone,
and carries on when playback ends.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from giraff_console.link.exchange import Exchange
from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.errors import ProtocolError
from giraff_console.recording.control_log import LogEntry, LogRead
from giraff_console.recording.playback import Playback, as_exchange
from giraff_console.recording.session import PoseSample, SessionStart
from giraff_console.robot.odometry import Odometry, Pose

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
    """A playback and the pose and motor state it implies.

    The pose after a seek is integrated again from the nearest point already passed, not
    from the start, so that seeking in an hour-long session stays quick: a checkpoint of
    the odometry is kept every CHECKPOINT_ENTRIES entries.
    """

    def __init__(self, playback: Playback) -> None:
        self.playback = playback
        self.odometry = starting_odometry(playback.start)
        self.state: MotorState | None = None
        self._done = 0  # entries interpreted so far
        # Entries interpreted -> (pose, odometry reference, state) at that point.
        self._checkpoints: dict[int, tuple[Pose, MotorState | None, MotorState | None]] = {
            0: (self.odometry.pose, self.odometry.reference, None)
        }

    def advance(self, now: float, notify: Callable[[Exchange], None]) -> None:
        """Hand out what has fallen due, and take the odometry along."""
        for entry in self.playback.due(now):
            exchange = as_exchange(entry, now)
            notify(exchange)
            self._interpret(entry)

    def seek(self, now: float, offset: float) -> None:
        """Move to `offset`, the pose with it."""
        target = self.playback.seek(now, offset)
        start = max(index for index in self._checkpoints if index <= target)
        pose, reference, self.state = self._checkpoints[start]
        self.odometry.reset(pose, reference)
        self._done = start
        for entry in self.playback.entries[start:target]:
            self._interpret(entry)

    def status(self, now: float) -> PlaybackStatus:
        playback = self.playback
        return PlaybackStatus(playback.name, min(playback.position(now), playback.duration),
                              playback.duration, playback.speed, playback.paused)  # fmt: skip

    @property
    def pose(self) -> Pose:
        return self.odometry.pose

    def _interpret(self, entry: LogEntry) -> None:
        self._done += 1
        state = recorded_state(entry)
        if state is not None:
            try:
                self.odometry.update(state)
                self.state = state
            except ProtocolError:
                pass  # a board without wheel distances: the pose cannot follow
        if self._done % CHECKPOINT_ENTRIES == 0:
            self._checkpoints[self._done] = (self.odometry.pose, self.odometry.reference,
                                             self.state)  # fmt: skip


def recorded_state(entry: LogEntry) -> MotorState | None:
    """The motor state an automatic `bulk_data` poll recorded; None for anything else.

    It is stamped with the recorded time, not the playback's, so that speed and seeks
    do not change what the odometry's plausibility check sees.
    """
    if not entry.frame_marker:
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
    """An odometry where the live one stood as recording began."""
    odometry = Odometry()
    reference = None
    if start.imdl is not None and start.imdr is not None:
        reference = MotorState(cang=0.0, cdis=0.0, gvr=0.0, speed=0.0, cvg=start.cvg, tilt=None,
                               imdl=start.imdl, imdr=start.imdr, mode=0,
                               received_at=start.offset)  # fmt: skip
    odometry.reset(Pose(start.x, start.y, start.heading), reference)
    return odometry


def replay_poses(log: LogRead, start: SessionStart | None = None) -> Iterator[PoseSample]:
    """The pose at every automatic `bulk_data` poll, as the console saw it."""
    odometry = starting_odometry(start or SessionStart())
    for entry in log.entries:
        state = recorded_state(entry)
        if state is None:
            continue
        try:
            pose = odometry.update(state)
        except ProtocolError:
            return
        yield PoseSample(entry.offset, pose.x, pose.y, pose.heading)
