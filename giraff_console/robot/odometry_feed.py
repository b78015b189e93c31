"""Feeding the odometry the way the board it is connected to needs (issue 13).

After each connection the control loop probes the board (link/board_probe.py) and this
chooses how to read its wheels from the `[board] odometers` setting and what the board
answered (wheel_odometers.choose_reading). Then it:

- polls bulk_data for the loop (`poll`), with the encoders when they are used or
  checked, and hands the odometry every other read of bulk_data it needs (`watch`): on
  later boards a read resets `imdl`/`imdr`, so a typed `get bulk_data` or the poll
  inside a stop would otherwise take its travel away;
- runs the first-motion check (odometer_check.py) until it has decided, told of every
  relative move that goes out. A reading it replaces changes the pose, so the loop ends
  any mission that was driving by the old one (`pose_jumped`). When no reading agrees,
  the pose cannot be trusted (`untrusted`): the loop stops a mission under way and
  refuses to start one, and the check runs again from the next motion until one passes;
- hands the missions `imdl`/`imdr` as totals whatever the board reports (`as_totals`):
  they measure a move's progress and stalls on the wheels, by differences;
- says whether a curve goes out as one `twm` (`moves`): the probe's answer to `get twm`,
  unless `[board] twm` says otherwise.

A board already checked, met again with the same answers to the probe after a lost
link, is not checked again.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import replace

from giraff_console.link import BoardFeatures, BoardLink, Exchange, MotorState
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import BoardError, BoardRebootedError, ProtocolError
from giraff_console.protocol.mode import ModeBit
from giraff_console.robot.odometer_check import CheckOutcome, OdometerCheck
from giraff_console.robot.odometry import Odometry
from giraff_console.robot.twm import combine_moves
from giraff_console.robot.wheel_odometers import AUTO, Reading, choose_reading, firmware_reading

log = logging.getLogger(__name__)

# Reads kept while no board is known: one per attempt to reconnect; a long outage's
# oldest are no use anyway.
UNFED_READS = 20
# How long the encoders may go unread before imdl/imdr take over. A count missed now and
# then costs nothing, since the next counts cover the gap; a second of misses is a board
# that no longer gives them.
ENCODERS_PATIENCE_S = 1.0
# What `[board] twm` may say: the probe decides, or the settings do.
TWM_CHOICES = (AUTO, "on", "off")

# A buffered move starts when the one before it ends, not when it is sent; an absolute
# one counts from elsewhere (A.4.8). The console's own moves are neither. (On later
# boards bit 2 selects degrees per second for vg instead, wire-facts; cdis is metres
# either way, but the console never sends it, so it is left out of the check too.)
_UNCOUNTED_MODE = ModeBit.ABSOLUTE | ModeBit.BUFFERED

# Why missions are refused while no wheel reading agrees with cdis, and what to do.
UNTRUSTED = ("the odometry disagrees with cdis, so the pose cannot be trusted: set [board] "
             "odometers and wheel_base and restart the console, or drive a metre by hand "
             "so that the check runs again")  # fmt: skip


class OdometryFeed:
    """The odometry's supply of samples, the reading it uses and its check."""

    def __init__(self, odometry: Odometry, setting: str = AUTO,
                 report: Callable[[str], None] = lambda message: None,
                 twm: str = AUTO) -> None:  # fmt: skip
        """`setting` and `twm` are `[board] odometers` and `[board] twm`."""
        if twm not in TWM_CHOICES:
            raise ValueError(f"twm must be one of {', '.join(TWM_CHOICES)}, not {twm!r}")
        self.odometry = odometry
        self.setting = setting
        self.twm = twm
        self.report = report
        self.features: BoardFeatures | None = None
        self.check: OdometerCheck | None = None
        # Set when the check replaced the reading, to the message: the pose changed.
        self.pose_jumped: str | None = None
        # Set while the pose cannot be trusted (UNTRUSTED): nothing agreed with cdis, and
        # no check has passed since.
        self.untrusted: str | None = None
        self._verified: tuple[BoardFeatures, Reading] | None = None
        # Reads of bulk_data while no board is known (a reconnect's stop); a few at most.
        self._unfed: collections.deque[MotorState] = collections.deque(maxlen=UNFED_READS)
        self._encoders_failed = False
        # While the encoders in use go unread: since when, why, and imdl/imdr's reading
        # integrated from the last counts (what takes over if they stay unread).
        self._gap: tuple[float, str, Odometry] | None = None

    # -- the connection -----------------------------------------------------------------

    def connected(self, features: BoardFeatures, powered_up: bool) -> None:
        """A board was reached and probed. `powered_up`: it greeted, so its counters
        started again; otherwise the samples continue from before the link was lost."""
        known = self._verified
        verified = known is not None and _same_board(known[0], features)
        if known is not None and verified:
            reading = known[1]
            self.untrusted = None  # whatever disagreed was another board
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
        self._gap = None
        self.check = None
        if not verified:
            self._start_check()

    def disconnected(self) -> None:
        self.features = None
        self._unfed.clear()
        self._gap = None

    def rebooted(self) -> None:
        """The board restarted: its counters too. Keep the pose, take new references."""
        self.odometry.reset(self.odometry.pose)
        self._gap = None
        if self.check is not None:
            self.check.restart(self.odometry.pose)

    def describe(self) -> str:
        """What the probe found and how the console uses it, for the status log."""
        assert self.features is not None
        return self.features.describe(self.odometry.reading, twm=self.uses_twm)

    # -- the loop's traffic -------------------------------------------------------------

    def poll(self, link: BoardLink) -> MotorState:
        """The loop's poll, with the encoders when they are read, into the odometry; the
        state as teleop and the missions read it, `imdl`/`imdr` as totals whatever the
        board. LinkError, a restarted board and a garbled bulk_data pass through."""
        exchange = link.send(Command("get", "bulk_data"), automatic=True)
        if not isinstance(exchange.value, dict):
            raise ProtocolError(f"bulk_data reply is not a list: {exchange.lines!r}")
        state = MotorState.from_bulk(exchange.value, exchange.answered_at)
        if self.needs_encoders:
            state = self._with_encoders(link, state)
        else:
            self._gap = None  # no longer needed: nothing to bridge
        self.sample(state, at=exchange.sent_at)
        return self.as_totals(state)

    def watch(self, exchange: Exchange, held: Mapping[str, str]) -> None:
        """Every exchange on the link, whoever sent it: moves and encoder settings for
        the check and the odometry, and reads of bulk_data other than the loop's polls.
        `held` is what the board now holds for its moves, as sent (Teleop.board_settings)."""
        if exchange.error is not None:
            return
        words = exchange.command.split()
        if exchange.kind == "set" and words[1] in ("p", "twm"):
            if self.check is not None:
                # When it was sent, not answered: see OdometerCheck.sample.
                self.check.move_sent(exchange.sent_at, counts=_path_move(held))
        elif exchange.kind == "set" and words[1] in ("enc0", "enc1"):
            self._encoders_set()
        elif (exchange.kind == "get" and not exchange.automatic and words == ["get", "bulk_data"]
              and isinstance(exchange.value, dict)):  # fmt: skip
            # The loop's own polls are fed by `poll`, with the encoders when read.
            try:
                state = MotorState.from_bulk(exchange.value, exchange.answered_at)
            except ProtocolError:
                return
            self.sample(state, automatic=False, at=exchange.sent_at)

    def mission_stop(self) -> str | None:
        """Why a mission under way must stop, if it must: the pose cannot be trusted, or
        it jumped when the check replaced the reading. Asking forgets the jump: a later
        mission starts from the pose as it is now."""
        jumped, self.pose_jumped = self.pose_jumped, None
        if self.untrusted is not None:
            return "stopped: its pose cannot be trusted (no wheel reading agrees with cdis)"
        if jumped is not None:
            return ("stopped: its pose was wrong (the odometry read the wheels the wrong "
                    "way); start it again")  # fmt: skip
        return None

    @property
    def uses_twm(self) -> bool:
        """Whether a curve goes out as one twm: `[board] twm`, or the probe's answer to
        `get twm` when it says auto (board_probe.py: an assumption)."""
        if self.features is None or self.twm == "off":
            return False
        return self.twm == "on" or self.features.twm

    def moves(self, commands: list[Command], held: Mapping[str, str]) -> list[Command]:
        """A batch of moves as it goes to this board: with twm, a curve is one command."""
        return combine_moves(commands, held) if self.uses_twm else commands

    # -- samples ------------------------------------------------------------------------

    @property
    def needs_encoders(self) -> bool:
        """Whether the loop's poll must read the encoders too."""
        if self.features is None or not self.features.encoders or self._encoders_failed:
            return False
        in_check = self.check is not None and Reading.ENCODERS in self.check.readings
        return self.odometry.reading is Reading.ENCODERS or in_check

    def _with_encoders(self, link: BoardLink, state: MotorState) -> MotorState:
        """`state` with the encoders' counts, read now; without them when they cannot be
        read (`sample` bridges the gap). LinkError and a restarted board pass through."""
        try:
            counts = [
                link.send(Command("get", name), automatic=True).value for name in ("enc0", "enc1")
            ]
        except BoardRebootedError:
            raise
        except (BoardError, ProtocolError) as error:
            self._encoders_unread(state, str(error))
            return state
        if not all(isinstance(c, int | float) and math.isfinite(c) for c in counts):
            self._encoders_unread(state, f"garbled counts {counts!r}")
            return state
        enc0, enc1 = counts
        assert isinstance(enc0, int | float) and isinstance(enc1, int | float)
        self._gap = None  # the counts are back, and cover the gap
        return replace(state, enc0=round(enc0), enc1=round(enc1))

    def _encoders_unread(self, state: MotorState, why: str) -> None:
        """The counts for `state` could not be read: note since when, and start
        integrating imdl/imdr from the last counts, in case they do not come back."""
        if self._gap is not None:
            self._gap = (self._gap[0], why, self._gap[2])
            return
        assert self.features is not None
        bridge = Odometry(self.odometry.pose, wheel_base=self.odometry.wheel_base,
                          reading=firmware_reading(self.features))  # fmt: skip
        reference = self.odometry.reference
        if reference is not None and bridge.odometers.usable(reference):
            bridge.reset(self.odometry.pose, reference)
        # The wheels' sums too (as_totals), so that the missions see no jump back.
        bridge.wheels = self.odometry.wheels
        self._gap = (state.received_at, why, bridge)

    def sample(self, state: MotorState, automatic: bool = True, at: float | None = None) -> None:
        """A read of bulk_data: the loop's poll (`automatic`), or any other; `at` is when
        it was sent (OdometerCheck.sample)."""
        if self.features is None:
            if not automatic:
                self._unfed.append(state)
            return
        if self._gap is not None and self._gap[2].wants(state, automatic):
            self._gap[2].update(state)
        if automatic and self.odometry.reading is Reading.ENCODERS:
            # A poll whose counts could not be read is skipped: the reference stays, and
            # the next counts cover the gap (or the bridge takes over, below).
            if self.odometry.odometers.usable(state):
                self.odometry.update(state)
        # The loop's own poll always goes in: a board without what the reading needs
        # is an error the loop reports (Odometry.update), not a pose that stands still.
        elif automatic or self.odometry.wants(state, automatic):
            self.odometry.update(state)
        if self.check is not None:
            outcome = self.check.sample(state, at)
            if outcome is not None:
                self._decided(outcome)
        if automatic and self._gap is not None:
            self._give_up_on_encoders(state)

    def _give_up_on_encoders(self, state: MotorState) -> None:
        """Counts unread for ENCODERS_PATIENCE_S: stop reading them, and read imdl/imdr
        from the last counts on (the bridge), if they were the reading."""
        assert self._gap is not None
        since, why, bridge = self._gap
        if state.received_at - since < ENCODERS_PATIENCE_S:
            return
        self._gap = None
        self._encoders_failed = True
        message = f"odometry: the encoders could not be read for {ENCODERS_PATIENCE_S:g} s ({why})"
        if self.odometry.reading is Reading.ENCODERS:
            self.odometry.take_over(bridge)
            self.odometry.wheels = bridge.wheels
            message += f"; reading imdl/imdr as {bridge.reading} instead"
        self.report(message + "; not read again until the board is reconnected")
        if self.check is not None and Reading.ENCODERS in self.check.readings:
            # It waits for counts that will not come: check what is read now instead.
            self._start_check()

    def as_totals(self, state: MotorState) -> MotorState:
        """`state` with `imdl`/`imdr` as metres turned since a fixed point, as the
        thesis's board reports them and the missions read them: the board's own on such
        a board, the odometry's sums of what it integrated on any other."""
        if self.odometry.reading is Reading.TOTALS:
            return state
        left, right = self.odometry.wheels
        return replace(state, imdl=left, imdr=right)

    def _encoders_set(self) -> None:
        """Someone set `enc0` or `enc1` (a typed `set enc0 0`, as drivers do at start):
        the counters jumped, the wheels did not. The pose stays; the next counts are a
        new reference."""
        if self.odometry.reading is Reading.ENCODERS:
            self.odometry.use(Reading.ENCODERS)
        if self.check is not None:
            self.check.encoders_set()

    def _start_check(self) -> None:
        assert self.features is not None
        source = "its firmware suggests" if self.setting == AUTO else "the settings say"
        self.check = OdometerCheck(self.odometry.reading, self.odometry.pose,
                                   encoders=self.features.encoders and not self._encoders_failed,
                                   wheel_base=self.odometry.wheel_base,
                                   source=source)  # fmt: skip

    def _decided(self, outcome: CheckOutcome) -> None:
        self.check = None
        was_untrusted = self.untrusted is not None
        if not outcome.agreed:
            # The pose may be wrong: missions stop and wait for a check that passes, which
            # the next motion (by hand) gives, since the settings cannot change meanwhile.
            self.untrusted = UNTRUSTED
            if was_untrusted:
                log.warning(outcome.message)  # said once already: not every 0.3 m driven
            else:
                self.report(f"{outcome.message}; missions are stopped and refused until a "
                            "check passes: set [board] odometers and wheel_base, or drive "
                            "a metre by hand to check again")  # fmt: skip
            self._start_check()
            return
        self.untrusted = None
        if self.features is not None:
            self._verified = (self.features, outcome.reading)
        if outcome.trusted and not was_untrusted:
            # All is as expected: the status log has little room, the log file has.
            log.info(outcome.message)
        else:
            again = "; missions may run again" if was_untrusted else ""
            self.report(outcome.message + again)
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
