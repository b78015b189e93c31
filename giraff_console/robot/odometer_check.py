"""The first-motion check: does the wheel reading in use agree with the board's `cdis`?

Whether a board's `imdl`/`imdr` are totals (the thesis's board) or increments (later
boards, wire-facts) is known from its firmware only by inference, and a board that
behaves unlike what the settings or its firmware suggest would make the pose garbage.
So during the first straight or curved motion after connecting, the centre travel of
the claimed reading is compared with what the board's move counter `cdis` says, and
the other interpretations are integrated alongside, from the same samples and pose.

`cdis` restarts with every relative move (A.4.8), and teleop and missions send a move
most ticks. So between two polls it measures `cdis_now - cdis_prev` when no move went
out between them, and `cdis_now` when one did: then only from the move's start, a few
milliseconds after the first poll, so it is scaled up by the time between the polls
over the time since the move (the speed barely changes in that much). Those times are
the board's: when each command reached it (see `sample`), not when its reply came back.
Only pairs of polls in straight or curved motion count, under a relative move: in
rotation `cdis` stays 0 or counts wheel metres (r < 0, B.2), and absolute moves count
from elsewhere.

Once `cdis` has measured DECIDE_AFTER_M, the claimed reading is trusted if it agrees
within TOLERANCE; otherwise the encoders, when the board has them and they agree, or
else the other interpretation of `imdl`/`imdr` that agrees, replace it, with the pose
integrated the right way from the start of the check. If nothing agrees the claimed
reading stays, untrusted, and the message says so: what follows from that (missions
stopped and refused, the check run again) is odometry_feed.py's. Pure: the feed hands
it samples and tells it when a move went out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.wheel_odometers import Reading

# cdis travel after which the readings are judged: well inside the first metre.
DECIDE_AFTER_M = 0.3
# How far a reading may differ from cdis and still agree with it.
TOLERANCE = 0.15


@dataclass(frozen=True)
class CheckOutcome:
    """What the check decided.

    `trusted` when the claimed reading agreed with cdis. Otherwise `reading` is what to
    read from now on; when it differs from the claimed one, `odometry` is the odometry to
    carry on from (its pose integrated that way all along); when it does not, nothing
    agreed and the pose cannot be trusted. `message` says what was found, for the status
    log.
    """

    claimed: Reading
    reading: Reading
    odometry: Odometry | None
    message: str
    trusted: bool = False

    @property
    def switched(self) -> bool:
        return self.reading is not self.claimed

    @property
    def agreed(self) -> bool:
        """Whether the reading now in use agrees with cdis: the claimed one or another."""
        return self.trusted or self.switched


class OdometerCheck:
    """Watches the first metre of path motion; `sample` returns the outcome once."""

    def __init__(self, claimed: Reading, pose: Pose, *, wheel_base: float,
                 encoders: bool, source: str = "the settings say") -> None:  # fmt: skip
        """`source` says where the claim came from, for the message: "the settings
        say", or "its firmware suggests" when the settings left it to the probe."""
        self.claimed = claimed
        self.source = source
        self.wheel_base = wheel_base
        readings = [claimed, *(r for r in (Reading.TOTALS, Reading.INCREMENTS) if r != claimed)]
        if encoders and claimed is not Reading.ENCODERS:
            readings.append(Reading.ENCODERS)
        self._readings = tuple(readings)
        self.outcome: CheckOutcome | None = None
        self._begin(pose)

    def _begin(self, pose: Pose) -> None:
        self._odometries = {
            reading: Odometry(pose, wheel_base=self.wheel_base, reading=reading)
            for reading in self._readings
        }
        # cdis's travel and each reading's, over the pairs of samples that count.
        self._cdis = 0.0
        self._travel = dict.fromkeys(self._readings, 0.0)
        # Each reading's distance at the previous sample.
        self._distances = dict.fromkeys(self._readings, 0.0)
        # The previous sample, and when the board took it (see `sample`).
        self._prev: tuple[MotorState, float] | None = None
        # The move in force counts (path, relative); a move sent since the last sample.
        self._counting = False
        self._sent: tuple[float, bool] | None = None

    @property
    def readings(self) -> Sequence[Reading]:
        """The readings integrated alongside: whoever feeds the check reads what they
        need (the encoders, when they are among them)."""
        return self._readings

    def move_sent(self, at: float, counts: bool) -> None:
        """A relative move (`set p`, `set twm`) was sent at `at` (the exchange's
        `sent_at`, as for `sample`); `counts` when it is a straight or curved one, in
        relative mode, whose `cdis` this check can use."""
        self._sent = (at, counts)

    def restart(self, pose: Pose) -> None:
        """The board restarted (its counters with it): start the check again at `pose`."""
        if self.outcome is None:
            self._begin(pose)

    def encoders_set(self) -> None:
        """Someone set `enc0` or `enc1` (a typed `set enc0 0`): the next counts start a
        new reference instead of counting the jump as travel."""
        odometry = self._odometries.get(Reading.ENCODERS)
        if odometry is not None:
            odometry.use(Reading.ENCODERS)

    def sample(self, state: MotorState, at: float | None = None) -> CheckOutcome | None:
        """Take one read of bulk_data (any, not only the console's polls; with the
        encoders' counts when they are read); the outcome when this sample decides.

        `at` is when the poll was sent (the exchange's `sent_at`; by default when its
        answer came): the board takes bulk_data's values, and starts a move, as the
        command's line end reaches it, a byte time after it was sent for a poll and a
        move alike (both lines are about 10 to 14 bytes), so the two sent times are as
        far apart as those instants. The answers are not: at 115200 baud bulk_data's
        takes about 14 ms on the wire and a set's echo about 2 ms, which would shorten
        the time since the move by 12 ms of a 50 ms tick and make cdis read 25-40 % low.
        """
        if self.outcome is not None:
            return None
        for odometry in self._odometries.values():
            if odometry.odometers.usable(state):
                odometry.update(state)
        taken = (state, state.received_at if at is None else at)
        prev, self._prev = self._prev, taken
        sent, self._sent = self._sent, None
        counted_before = self._counting
        if sent is not None:
            self._counting = sent[1]
        if prev is None:
            self._note_distances()
            return None
        measure = self._cdis_measure(prev, taken, sent, counted_before)
        if measure is not None:
            self._cdis += abs(measure)
            for reading, odometry in self._odometries.items():
                self._travel[reading] += odometry.distance - self._distances[reading]
        self._note_distances()
        # A reading this sample lacked (encoder counts that could not be read, or not
        # read with a typed `get bulk_data`) lags until its next sample: not judged now.
        complete = all(odometry.odometers.usable(state) for odometry in self._odometries.values())
        if self._cdis >= DECIDE_AFTER_M and complete:
            self.outcome = self._decide()
            return self.outcome
        return None

    def _note_distances(self) -> None:
        for reading, odometry in self._odometries.items():
            self._distances[reading] = odometry.distance

    def _cdis_measure(self, prev_taken: tuple[MotorState, float],
                      taken: tuple[MotorState, float], sent: tuple[float, bool] | None,
                      counted_before: bool) -> float | None:  # fmt: skip
        """What cdis says the centre travelled between two samples, each with when the
        board took it; None when it cannot say (rotation, absolute moves, a move too
        late in the interval)."""
        (prev, prev_at), (state, at) = prev_taken, taken
        if not self._counting or state.absolute or prev.absolute:
            return None
        if sent is None:
            return state.cdis - prev.cdis
        if not counted_before:
            return None  # from a rotation or a stop into a path: part of it unmeasured
        elapsed = at - prev_at
        since_move = at - sent[0]
        if elapsed <= 0 or since_move < elapsed / 2:
            return None
        return state.cdis * min(elapsed / since_move, 2.0)

    def _decide(self) -> CheckOutcome:
        cdis = self._cdis

        def agrees(reading: Reading) -> bool:
            return abs(self._travel[reading] - cdis) <= TOLERANCE * cdis

        claimed = self.claimed
        said = f"over {cdis:.2f} m by cdis they read {self._travel[claimed]:.2f} m"
        if agrees(claimed):
            return CheckOutcome(claimed, claimed, None,
                                f"odometry checked: {_what(claimed)} agree with cdis over "
                                f"{cdis:.2f} m", trusted=True)  # fmt: skip
        wheels = (Reading.TOTALS, Reading.INCREMENTS)
        # What imdl/imdr really are, if one interpretation agrees; the encoders first.
        really = next((r for r in wheels if r is not claimed and agrees(r)), None)
        encoders = Reading.ENCODERS in self._odometries and agrees(Reading.ENCODERS)
        choice = Reading.ENCODERS if encoders and claimed is not Reading.ENCODERS else really
        if choice is not None:
            if claimed is Reading.ENCODERS:
                problem = f"the wheel encoders disagree with cdis ({said})"
            elif really is not None:
                problem = (f"the board's imdl/imdr behave as {really}, not as {claimed} as "
                           f"{self.source}: {said}")  # fmt: skip
            else:
                problem = (f"the board's imdl/imdr do not behave as {claimed}, as "
                           f"{self.source}: {said}")  # fmt: skip
            return CheckOutcome(claimed, choice, self._odometries[choice],
                                f"odometry: {problem}; now reading {_what(choice)}")  # fmt: skip
        return CheckOutcome(claimed, claimed, None,
                            f"odometry: no wheel reading agrees with cdis ({_what(claimed)}: "
                            f"{said}); still reading {claimed}, but the pose cannot be "
                            "trusted")  # fmt: skip


def _what(reading: Reading) -> str:
    return "the wheel encoders" if reading is Reading.ENCODERS else f"imdl/imdr as {reading}"
