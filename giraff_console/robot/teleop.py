"""Keyboard driving with the thesis's lookahead scheme (§3.2.1.2, B.2 RunMotor).

The board moves to a target and stops there, so driving "as long as a key is held"
means keeping a target ahead of the robot: k times the braking distance, renewed every
control tick. The board keeps executing the last `set p` if the console dies, so k
bounds the runaway: k = 1.5 leaves at most 1.5 * 0.16 m = 0.24 m at 0.4 m/s and
0.5 m/s^2, within the console's reach of 0.25 m (robot/safety.py: design.md's 0.3 m rule
less a margin for a loaded machine). In a curve the outer wheel keeps to the speed, so
the middle of the robot goes slower and its target is nearer. When the deadman lets go, the target
becomes the braking distance plus 10 ms of travel, which stops without the reversal a
shorter target would cause.

Forward plus a turn is curved motion with the gear ratio of B.2 CalcMove, capped below
0.51 (§3.2.1.4); a turn alone rotates in place. Leaving a curve ramps the gear ratio
down by `vgr` rather than forcing `vgr 0`, which would jerk (§3.2.1.4).
"""

from __future__ import annotations

from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.codec import Command, Number, format_number, names_set, settings_of
from giraff_console.protocol.errors import CommandError
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, brake_distance
from giraff_console.robot.deadman import Intent
from giraff_console.robot.safety import (
    REACH_M,
    RUNAWAY_M,
    path_stop_distance,
    rotation_stop_angle,
    rotation_wheel_speed,
)

# The target is renewed once it is closer than the braking distance plus this many ticks.
RENEW_TICKS = 2
# A stop that has left the wheels still for this long, with the board still reporting
# its move, is held up by something (a wall, a box): the move is given up with a target
# of nothing, which the board ends at once from a standstill (B.2 StartStraight), so
# that nothing is left pending to lurch on when the way clears.
STALLED_STOP_S = 1.0
# A held key's move under way with the wheels still this long is blocked (a wall, a box):
# said, so that an operator holding Up against a wall is not left reading "moving 0.00
# m/s" (issue 26). The second a mission's executor takes to call a stall (§2.3.2).
BLOCKED_S = 1.0
# Said once: again only after this long not blocked (a gap in a key's repeats over a
# jittery SSH link unblocks it for a second or so, and a note each time is noise).
BLOCKED_SAID_AGAIN_S = 5.0
# Wheels turning slower than this are still: the simulated board reads 9e-16 m/s, not
# 0, against a wall.
STILL_WHEELS = 1e-3
# r for curved motion (A.4.2 needs r > 50); the thesis's console used 1000.
PATH_STYLE = 1000
ROTATE_STYLE = 0


@dataclass(frozen=True)
class DriveLimits:
    """Speeds and limits for teleop; checked against the safety rules on creation."""

    speed: float = 0.4  # KBD_MOVE_SPEED (B.7)
    max_speed: float = 0.4
    accel: float = 0.5  # DEF_ACCEL (B.2)
    turn_rate: float = 45.0  # KBD_TURN_SPEED, degrees per second (B.7)
    max_gear: float = 0.5  # |vg| < 0.51 (§3.2.1.4)
    gear_rate: float = 1.0  # DEF_VGACCEL, per metre (B.2)
    lookahead: float = 1.5  # k: the target is k braking distances ahead
    runaway: float = RUNAWAY_M  # metres a dead console may let the robot go (design.md)
    reach: float = REACH_M  # metres ahead a target may lie, on the outer wheel (safety.py)

    @property
    def min_accel(self) -> float:
        """The gentlest acceleration that still stops from max_speed within the reach:
        what a move may use when how fast the robot goes is not known (a typed one)."""
        return self.max_speed**2 / (2 * self.reach)

    def __post_init__(self) -> None:
        if not 0 < self.speed <= self.max_speed:
            raise ValueError("speed must be positive and at most max_speed")
        if self.turn_rate <= 0 or self.gear_rate <= 0:
            raise ValueError("turn rate and gear rate must be positive")
        if self.accel < self.min_accel:
            raise ValueError(
                f"accel must be at least {self.min_accel:.3f} m/s^2 to stop from max_speed "
                f"within {self.reach} m"
            )
        if not 0 <= self.max_gear < 0.51:
            raise ValueError("max_gear must be below 0.51 (§3.2.1.4)")
        if self.lookahead <= 1:
            raise ValueError("lookahead must exceed 1, or the board would brake and reverse")
        if self.lookahead * brake_distance(self.max_speed, self.accel) > self.reach:
            raise ValueError(
                f"at max_speed {self.max_speed} m/s a dead console would let the robot run "
                f"{self.lookahead * brake_distance(self.max_speed, self.accel):.2f} m, "
                f"over the {self.reach} m limit"
            )


def still(state: MotorState) -> bool:
    """The wheels are not turning (a reading that is not a number is not still)."""
    return abs(state.gvr) < STILL_WHEELS


class Teleop:
    """Turns the held intent and the latest motor state into board commands."""

    def __init__(self, limits: DriveLimits | None = None, tick: float = 0.05) -> None:
        """`tick` is the control period, used to renew the target in good time."""
        self.limits = limits or DriveLimits()
        self.tick = tick
        self.speed = self.limits.speed
        self._target = 0.0
        self._style: int | None = None
        self._stopping = False
        self._still_since: float | None = None
        self._blocked_since: float | None = None  # a held key's move, the wheels still
        self._still_long = False  # ... for BLOCKED_S
        # Whether blocked has been said, and since when it has not been blocked.
        self._blocked_said = False
        self._free_since: float | None = None
        self.newly_blocked = False  # blocked, and not said yet: the loop says it
        # What the board holds for its next move, as sent on the wire (board_set).
        self._board: dict[str, str] = {}

    def set_speed(self, speed: float) -> float:
        """Change the driving speed within (0, max_speed]; returns the speed now set."""
        self.speed = min(max(speed, 0.05), self.limits.max_speed)
        return self.speed

    def board_set(self, name: str, text: str | None) -> None:
        """The board took `set NAME TEXT`, from teleop or from anyone else; None: what
        it holds for NAME is not known (the answer to the set went wrong). A Giraff-X
        `set twm` (TEXT `vg cdp vgr v p 0`) sets the five settings it carries."""
        settings = None
        if text is not None:
            try:
                settings = settings_of(name, text)
            except CommandError:
                settings = None  # not a set the board takes as written: unknown
        if settings is None:
            # A twm whose answer went wrong leaves all it carries unknown.
            for unknown in names_set(name):
                self._board.pop(unknown, None)
        else:
            self._board.update(settings)

    @property
    def board_r(self) -> float | None:
        """The board's movement style as last set, if known (A.4.2)."""
        text = self._board.get("r")
        return None if text is None else float(text)

    @property
    def board_settings(self) -> dict[str, str]:
        """A copy of what the board holds for its next move, as sent on the wire."""
        return dict(self._board)

    def safe_settings(self) -> list[Command]:
        """Settings for a board just reached: its power-up defaults (v = a = 0.6, vg = 1)
        are outside the limits, and a typed `set p` would use them."""
        plan: dict[str, Number] = {
            "r": PATH_STYLE, "mode": 0, "a": self.limits.accel, "v": self.speed, "vg": 0,
            "vgr": self.limits.gear_rate, "cdp": 0,
        }  # fmt: skip
        return [Command("set", name, value) for name, value in plan.items()]

    def halt(self) -> None:
        """The robot was stopped by other means (a playback began): teleop is idle."""
        self._style = None
        self._stopping = False
        self._blocked_since = None

    def forget_board(self) -> None:
        """The board's settings are unknown again (a new connection, a restart)."""
        self._board.clear()
        self._style = None
        self._stopping = False
        self._blocked_since = None

    @property
    def active(self) -> bool:
        """True while teleop has the robot moving or stopping."""
        return self._style is not None

    @property
    def blocked(self) -> bool:
        """A held key's move has been under way for BLOCKED_S with the wheels still."""
        return self.active and not self._stopping and self._still_long

    def step(self, intent: Intent | None, state: MotorState) -> list[Command]:
        """The commands for this control tick, in order."""
        self._watch_blocked(intent, state)
        commands = self._step(intent, state)
        self._news(state.received_at)
        return commands

    def _news(self, now: float) -> None:
        """Whether being blocked is news to say now (`newly_blocked`)."""
        blocked = self.blocked
        self.newly_blocked = blocked and not self._blocked_said
        if blocked:
            self._blocked_said, self._free_since = True, None
        elif self._blocked_said:
            if self._free_since is None:
                self._free_since = now
            elif now - self._free_since >= BLOCKED_SAID_AGAIN_S:
                self._blocked_said = False

    def _step(self, intent: Intent | None, state: MotorState) -> list[Command]:
        if not state.moving and self._stopping:
            self._style, self._stopping = None, False
        if self._stopping and self._held_up(state):
            self._style, self._stopping = None, False
            return [Command("set", "p", 0)]
        if state.estop:
            self._style, self._stopping = None, False
            return []
        if intent is None:
            return self._stop(state) if self._style is not None and state.moving else []
        style = PATH_STYLE if intent.motion else ROTATE_STYLE
        if self._style is not None and self._style != style:
            # Change style only from a standstill, as the thesis did.
            return self._stop(state) if state.moving else self._start(intent, style)
        if self._style is None or self._stopping:
            return self._start(intent, style)
        return self._renew(intent, state)

    # -- commands -----------------------------------------------------------------------

    def _plan(self, intent: Intent, style: int) -> dict[str, Number]:
        limits = self.limits
        if style == ROTATE_STYLE:
            wheel_speed = limits.turn_rate / TURN_FACTOR_DEG_PER_M
            ahead = limits.lookahead * brake_distance(wheel_speed, limits.accel)
            return {"v": wheel_speed, "p": intent.turn * ahead * TURN_FACTOR_DEG_PER_M}
        gear = 0.0
        if intent.turn:
            # B.2 CalcMove: the ratio that turns at turn_rate while moving at speed.
            gear = min(limits.turn_rate / (self.speed * TURN_FACTOR_DEG_PER_M), limits.max_gear)
        # In a curve the outer wheel goes 1 + |vg| times as fast and as far as the middle
        # (A.2.3): it is the outer wheel that keeps to the speed and the reach.
        speed = round(self.speed / (1 + gear), 4)
        ahead = limits.lookahead * brake_distance(speed, limits.accel)
        plan: dict[str, Number] = {"v": speed, "vgr": limits.gear_rate}
        if gear:
            plan.update(vg=intent.turn * gear, vgr=intent.turn * limits.gear_rate)
        # The ratio ramps back down from cdp: at the target while turning, at once if not.
        plan["cdp"] = intent.motion * ahead if gear else 0
        plan["p"] = intent.motion * ahead
        return plan

    def _start(self, intent: Intent, style: int) -> list[Command]:
        self._style, self._stopping = style, False
        return self._commands({"r": style, "mode": 0, "a": self.limits.accel,
                               **self._plan(intent, style)})  # fmt: skip

    def _renew(self, intent: Intent, state: MotorState) -> list[Command]:
        """Keep the target ahead, renewing it only when the robot is getting close.

        With k = 1.5 the thesis's "renew when less than 2 braking distances are left"
        would renew every tick; instead the target is renewed once less than the braking
        distance plus two ticks of travel is left, which keeps the board from being sent
        the same `set p` twenty times a second.
        """
        assert self._style is not None
        plan = self._plan(intent, self._style)
        counter = state.cang if self._style == ROTATE_STYLE else state.cdis
        left = abs(self._target) - abs(counter)
        speed = abs(plan["v"])
        margin = abs(plan["p"]) / self.limits.lookahead + speed * RENEW_TICKS * self.tick
        # The other way at once (backing away from a wall, whose stalled wheels would
        # never bring the old target near enough to renew).
        reversed_ = plan["p"] * self._target < 0
        if self._unsent(plan) or left < margin or reversed_:
            return self._commands(plan)
        return []

    def _commands(self, plan: dict[str, Number]) -> list[Command]:
        """The settings the board does not hold yet, then the target.

        The target is relative, so it goes out every tick even when unchanged; it must
        come last, since `set p` starts the move with whatever is set by then.
        """
        self._target = float(plan["p"])
        return [Command("set", name, plan[name]) for name in [*self._unsent(plan), "p"]]

    def _unsent(self, plan: dict[str, Number]) -> list[str]:
        """The settings of `plan`, besides the target, that the board does not hold."""
        return [
            name
            for name, value in plan.items()
            if name != "p" and self._board.get(name) != format_number(value)
        ]

    def _watch_blocked(self, intent: Intent | None, state: MotorState) -> None:
        driving = intent is not None and self._style is not None and not self._stopping
        if not (driving and state.moving and still(state)):
            self._blocked_since = None
        elif self._blocked_since is None:
            self._blocked_since = state.received_at
        self._still_long = (self._blocked_since is not None
                            and state.received_at - self._blocked_since >= BLOCKED_S)  # fmt: skip

    def _held_up(self, state: MotorState) -> bool:
        """Whether the stop has had the wheels still for STALLED_STOP_S while the board
        still holds the move."""
        if not state.moving or not still(state):
            self._still_since = None
            return False
        if self._still_since is None:
            self._still_since = state.received_at
        return state.received_at - self._still_since >= STALLED_STOP_S

    def _stop(self, state: MotorState) -> list[Command]:
        """Brake to a stop: the braking distance plus the reaction margin (§3.2.1.2)."""
        if self._stopping:
            return []
        self._stopping = True
        self._still_since = None
        limits = self.limits
        if self._style == ROTATE_STYLE:
            wheel = rotation_wheel_speed(state, ROTATE_STYLE)
            return self._commands({"p": rotation_stop_angle(wheel, limits.accel)})
        return self._commands({"cdp": 0, "p": path_stop_distance(state.speed, limits.accel)})
