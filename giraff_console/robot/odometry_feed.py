"""Feeding the odometry the way the board it is connected to needs (issue 13).

After each connection the control loop probes the board (link/board_probe.py) and this
chooses how to read its wheels from the `[board] odometers` setting and what the board
answered (wheel_odometers.choose_reading). Then it:

- hands the odometry every read of bulk_data it needs: the loop's own polls, and, for
  later boards whose `imdl`/`imdr` a read resets, any other read too (a typed
  `get bulk_data`, the poll inside a stop), which would otherwise take its travel away;
- reads the encoders after the loop's poll when they are used, or checked;
- runs the first-motion check (odometer_check.py) until it has decided, told of every
  relative move that goes out; a reading it replaces changes the pose, so the loop
  ends any mission that was driving by the old one (`pose_jumped`);
- hands the missions `imdl`/`imdr` as totals whatever the board reports (`as_totals`):
  they measure a move's progress and stalls on the wheels, by differences.

A board already checked, met again with the same answers to the probe after a lost
link, is not checked again.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import replace

from giraff_console.link import BoardFeatures, BoardLink, MotorState
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import BoardError, BoardRebootedError, ProtocolError
from giraff_console.protocol.mode import ModeBit
from giraff_console.robot.odometer_check import CheckOutcome, OdometerCheck
from giraff_console.robot.odometry import Odometry
from giraff_console.robot.wheel_odometers import AUTO, Reading, choose_reading, firmware_reading

log = logging.getLogger(__name__)

# Reads kept while no board is known: one per attempt to reconnect; a long outage's
# oldest are no use anyway.
UNFED_READS = 20

# A buffered move starts when the one before it ends, not when it is sent; an absolute
# one counts from elsewhere (A.4.8). The console's own moves are neither. (On later
# boards bit 2 selects degrees per second for vg instead, wire-facts; cdis is metres
# either way, but the console never sends it, so it is left out of the check too.)
_UNCOUNTED_MODE = ModeBit.ABSOLUTE | ModeBit.BUFFERED


class OdometryFeed:
    """The odometry's supply of samples, the reading it uses and its check."""

    def __init__(self, odometry: Odometry, setting: str = AUTO,
                 report: Callable[[str], None] = lambda message: None) -> None:  # fmt: skip
        self.odometry = odometry
        self.setting = setting
        self.report = report
        self.features: BoardFeatures | None = None
        self.check: OdometerCheck | None = None
        # Set when the check replaced the reading, to the message: the pose changed.
        self.pose_jumped: str | None = None
        self._verified: tuple[BoardFeatures, Reading] | None = None
        # Reads of bulk_data while no board is known (a reconnect's stop); a few at most.
        self._unfed: collections.deque[MotorState] = collections.deque(maxlen=UNFED_READS)
        self._encoders_failed = False

    # -- the connection -----------------------------------------------------------------

    def connected(self, features: BoardFeatures, powered_up: bool) -> None:
        """A board was reached and probed. `powered_up`: it greeted, so its counters
        started again; otherwise the samples continue from before the link was lost."""
        known = self._verified
        verified = known is not None and _same_board(known[0], features)
        if known is not None and verified:
            reading = known[1]
        else:
            reading, problem = choose_reading(self.setting, features)
            if problem is not None:
                self.report(problem)
        unfed = list(self._unfed)
        self._unfed.clear()
        if powered_up or reading is not self.odometry.reading:
            self.odometry.use(reading)
        else:
            for state in unfed:
                if self.odometry.wants(state, automatic=False):
                    self.odometry.update(state)
        self.features = features
        self._encoders_failed = False
        self.check = None
        if not verified:
            source = "its firmware suggests" if self.setting == AUTO else "the settings say"
            self.check = OdometerCheck(reading, self.odometry.pose, encoders=features.encoders,
                                       wheel_base=self.odometry.wheel_base,
                                       source=source)  # fmt: skip

    def disconnected(self) -> None:
        self.features = None
        self._unfed.clear()

    def rebooted(self) -> None:
        """The board restarted: its counters too. Keep the pose, take new references."""
        self.odometry.reset(self.odometry.pose)
        if self.check is not None:
            self.check.restart(self.odometry.pose)

    # -- samples ------------------------------------------------------------------------

    @property
    def needs_encoders(self) -> bool:
        """Whether the loop's poll must read the encoders too."""
        if self.features is None or not self.features.encoders or self._encoders_failed:
            return False
        in_check = self.check is not None and Reading.ENCODERS in self.check.readings
        return self.odometry.reading is Reading.ENCODERS or in_check

    def with_encoders(self, link: BoardLink, state: MotorState) -> MotorState:
        """`state` with the encoders' counts, read now; without, reported once, if the
        board will not give them. LinkError and a restarted board pass through."""
        try:
            counts = [
                link.send(Command("get", name), automatic=True).value for name in ("enc0", "enc1")
            ]
        except BoardRebootedError:
            raise
        except (BoardError, ProtocolError) as error:
            self._encoders_failed = True
            message = f"odometry: the encoders could not be read ({error})"
            if self.odometry.reading is Reading.ENCODERS:
                assert self.features is not None
                fallback = firmware_reading(self.features)
                self.odometry.use(fallback)
                message += f"; reading imdl/imdr as {fallback} instead"
            self.report(message + "; not read again until the board is reconnected")
            return state
        enc0, enc1 = counts
        if not all(isinstance(c, int | float) and math.isfinite(c) for c in (enc0, enc1)):
            return state  # garbled: this sample goes without
        assert isinstance(enc0, int | float) and isinstance(enc1, int | float)
        return replace(state, enc0=round(enc0), enc1=round(enc1))

    def sample(self, state: MotorState, automatic: bool = True) -> None:
        """A read of bulk_data: the loop's poll (`automatic`), or any other."""
        if self.features is None:
            if not automatic:
                self._unfed.append(state)
            return
        # The loop's own poll always goes in: a board without what the reading needs
        # is an error the loop reports (Odometry.update), not a pose that stands still.
        if automatic or self.odometry.wants(state, automatic):
            self.odometry.update(state)
        if self.check is not None:
            outcome = self.check.sample(state)
            if outcome is not None:
                self._decided(outcome)

    def as_totals(self, state: MotorState) -> MotorState:
        """`state` with `imdl`/`imdr` as metres turned since a fixed point, as the
        thesis's board reports them and the missions read them: the board's own on such
        a board, the odometry's sums of what it integrated on any other."""
        if self.odometry.reading is Reading.TOTALS:
            return state
        left, right = self.odometry.wheels
        return replace(state, imdl=left, imdr=right)

    def move_sent(self, at: float, held: Mapping[str, str]) -> None:
        """A `set p` or `set twm` went out at `at`; `held` is what the board now holds for
        its moves, as sent (Teleop.board_settings)."""
        if self.check is not None:
            self.check.move_sent(at, counts=_path_move(held))

    def _decided(self, outcome: CheckOutcome) -> None:
        self.check = None
        if self.features is not None:
            self._verified = (self.features, outcome.reading)
        if outcome.trusted:
            # All is as expected: the status log has little room, the log file has.
            log.info(outcome.message)
        else:
            self.report(outcome.message)
        if outcome.switched and outcome.odometry is not None:
            self.odometry.take_over(outcome.odometry)
            self.pose_jumped = outcome.message


def _same_board(known: BoardFeatures, now: BoardFeatures) -> bool:
    """The same answers to the probe, and the same version if both greeted: a board met
    again without a power cycle (a pty, a cable put back) does not greet."""
    versions = known.version is None or now.version is None or known.version == now.version
    return versions and replace(known, version=None) == replace(now, version=None)


def _path_move(held: Mapping[str, str]) -> bool:
    """Whether the move the board was just given is straight or curved and relative."""
    try:
        style = float(held["r"])
        mode = int(float(held["mode"]))
    except (KeyError, ValueError):
        return False
    return style > 0 and not mode & _UNCOUNTED_MODE
