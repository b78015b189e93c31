"""What a real Giraff does that an ideal board would not: off by default, seedable.

- The wheels rarely hit the requested distance exactly; the board reports what they
  really did, a few millimetres off (§5.5).
- The swivel casters must realign after turning in place, and turn the robot by up to
  about 45 degrees more before they have (§3.2.1.5): "Worst case, if you turn in place
  for a bit, and then try to start moving forward, these casters may cause the Giraff
  to turn up to about 45 degrees extra before they've finally reoriented themselves."
  The wheel odometry never sees it.
- A wheel can stall: motion is commanded but the odometry stops changing (§2.3.2).
- The board can raise ESTOP when something with the wheels is wrong (A.4.8).

Stalls and ESTOPs come at rates per second of motion, not per move: a console that
renews its move every tick (teleop, a streamed path) sends twenty moves a second, and
the wheels do not fail twenty times as often for it.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass


@dataclass(frozen=True)
class Imperfections:
    """Rates and sizes of the imperfections; the defaults describe an ideal board."""

    move_error_m: float = 0.0
    caster_drift_deg: float = 0.0
    caster_settle_m: float = 0.3
    stall_rate: float = 0.0  # stalls per second of motion
    stall_seconds: tuple[float, float] = (0.5, 2.0)
    estop_rate: float = 0.0  # ESTOPs per second of motion
    estop_seconds: float = 3.0
    seed: int | None = None

    @classmethod
    def realistic(cls, seed: int | None = None) -> Imperfections:
        """The `--imperfect` set: the thesis's observations at plausible rates."""
        return cls(
            move_error_m=0.003,
            # §3.2.1.5's worst case; a turn in place leaves 30 % to 100 % of it (below).
            caster_drift_deg=45.0,
            stall_rate=0.005,
            estop_rate=0.001,
            seed=seed,
        )


@dataclass(frozen=True)
class Mishap:
    """Something that will go wrong during a move, `after` seconds into it."""

    after: float
    seconds: float


class ImperfectionModel:
    """Draws the imperfections move by move from one seeded random stream."""

    def __init__(self, config: Imperfections) -> None:
        self.config = config
        self._random = random.Random(config.seed)
        self._caster_misalignment = 0.0
        # Seconds of motion until the next stall and the next ESTOP.
        self._stall_in = self._wait(config.stall_rate)
        self._estop_in = self._wait(config.estop_rate)

    def _wait(self, rate: float) -> float:
        return self._random.expovariate(rate) if rate > 0 else math.inf

    def distance_error(self) -> float:
        """Metres by which the next move misses its target."""
        sigma = self.config.move_error_m
        if sigma <= 0:
            return 0.0
        return max(-3 * sigma, min(3 * sigma, self._random.gauss(0.0, sigma)))

    def stall(self, move_seconds: float) -> Mishap | None:
        """The stall due within a move of `move_seconds`, or None."""
        if self._stall_in >= move_seconds:
            return None
        low, high = self.config.stall_seconds
        return Mishap(self._stall_in, self._random.uniform(low, high))

    def estop(self, move_seconds: float) -> Mishap | None:
        """The ESTOP due within a move of `move_seconds`, or None."""
        if self._estop_in >= move_seconds:
            return None
        return Mishap(self._estop_in, self.config.estop_seconds)

    def moved(self, seconds: float) -> None:
        """The wheels were driven for `seconds`: the next mishaps come that much closer."""
        self._stall_in = max(0.0, self._stall_in - seconds)
        self._estop_in = max(0.0, self._estop_in - seconds)

    def stalled(self) -> None:
        """The stall due has happened: the next one is drawn."""
        self._stall_in = self._wait(self.config.stall_rate)

    def estopped(self) -> None:
        """The ESTOP due has happened: the next one is drawn."""
        self._estop_in = self._wait(self.config.estop_rate)

    def rotated_in_place(self, degrees: float) -> None:
        """Note a rotation in place: the casters are now out of line with the wheels.

        A caster swings round as the robot turns on the spot, fully across after about a
        quarter turn; how much it then turns the robot as it realigns varies with the
        floor, up to the thesis's "about 45 degrees extra" (§3.2.1.5) and never more: a
        caster cannot be further out of line than across, however long the robot turned
        (a console's teleop renews its rotation twenty times a second, and a long turn
        so noted piece by piece must not add up beyond it). A turn the other way swings
        it back."""
        worst = math.radians(self.config.caster_drift_deg)
        if worst <= 0 or degrees == 0:
            return
        share = min(1.0, abs(degrees) / 90.0) * self._random.uniform(0.3, 1.0)
        # Clockwise rotation (positive `set p`) leaves the robot turning further clockwise.
        misalignment = self._caster_misalignment - math.copysign(worst * share, degrees)
        self._caster_misalignment = max(-worst, min(worst, misalignment))

    @property
    def misaligned(self) -> bool:
        """True while the casters still have turning to do."""
        return self._caster_misalignment != 0.0

    def caster_turn(self, distance: float) -> float:
        """Extra heading change (radians) while the casters realign over `distance` metres."""
        turn = self.caster_turn_over(distance)
        self.caster_turned(turn)
        return turn

    def caster_turn_over(self, distance: float) -> float:
        """The extra heading change (radians) the casters would make over `distance`
        metres of travel, without making it: the misalignment left decays by e every
        `caster_settle_m` (95 % settled within three times it), forwards or backwards."""
        if self._caster_misalignment == 0.0 or distance == 0.0:
            return 0.0
        settled = 1.0 - math.exp(-abs(distance) / self.config.caster_settle_m)
        return self._caster_misalignment * settled

    def caster_turned(self, turn: float) -> None:
        """The robot made `turn` (radians) of the casters' extra turn: less is left. A
        robot stopped by a wall part of the way makes only part of it."""
        if turn == 0.0:
            return
        self._caster_misalignment -= turn
        if abs(self._caster_misalignment) < 1e-9:
            self._caster_misalignment = 0.0  # realigned, to well below a micro-radian
