"""The one guard every command for the board passes, whoever sends it (design.md).

The command line, `giraff-console send` and the missions all send through
`check_command`: the board is told nothing the guard has not checked, in the very form
that goes on the wire (the value as `format_number` writes it, the name in lower case as
`parse_command` writes it).

- A `get` must name something the board can read (A.4); a bare command must be one the
  board knows, and it knows only `home` (A.4.10; B.2's SimulateCommand answers anything
  else with `Unknown name`). Reads and homing do not move the wheels.
- A `set` must name a setting in `setting_bounds`, the table of what each may be and
  why; anything else is refused. `set undock` is refused outright (REFUSED_SETTINGS).
- A move (`set p`) is allowed only when everything it will use is known and within the
  bounds, and it may not put the robot further ahead than the console's reach
  (`DriveLimits.reach`, robot/safety.py), on the outer wheel in a curve; in rotation
  (r = 0) `p` is in degrees (A.2.2).
- A Giraff-X `set twm vg cdp vgr v p 0` (wire-facts, "Later firmware") is checked as the
  move it is: each value within the bounds of its own setting, the closing value 0, and
  then the move as a `set p` with the board's settings overlaid by the twm's own. It
  carries its own curvature whatever the board's r (wire-facts, "What the deployed
  drivers do": a driver leaves r = 50 and still curves), so it is a curve on the outer
  wheel; in mode 2 what it means is not documented, and it is refused.
- Later boards' undocumented `mode 2` (wire-facts): `v` and `p` as in relative mode, `vg`
  an angular velocity in degrees per second, positive to the left. A move in it curves
  by the gear ratio radians(vg) / v * 0.2495 (wire-facts, "Quirks"), held below the
  thesis's 0.51 and reaching as far on the outer wheel; with v = 0 it turns on the spot
  at vg, at most MAX_SPIN_DEG_S, by |p| metres of each wheel (the simulator's reading
  of what the drivers send, sim/move.py `mode2_spin`). `r` is not read in it.
- No line is longer than MAX_LINE_CHARS.

The board brakes at the acceleration `a` of its last move, so `a` bounds a runaway too:
from a speed u the robot needs u^2 / 2a to stop, and a target nearer than that is
braked through (B.2). A typed command is checked without knowing how fast the robot
goes, so `a` must stop it from the top speed within the reach. A mission's commands
are checked on the control loop's thread right after a poll, knowing the speed the
robot may have when the move starts; its moves may use any acceleration that still
stops the robot within design.md's runaway limit from that speed, which is what lets a
jerk-limited profile ease into and out of its ramps. (The executor itself keeps every
stop within its target: motion/executor.py.)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from giraff_console.protocol.codec import DECIMALS, TWM, TWM_SETTINGS, Command, format_number
from giraff_console.protocol.errors import CommandError
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M, TURN_RADIUS_M
from giraff_console.robot.teleop import DriveLimits

# The longest line sent, CR not counted. The firmware's input buffer is documented
# nowhere: Appendix A gives no size, Appendix B is the host's side only (its 256-byte
# `buf` is what GiraffMotor reads replies into), and wire-facts is silent; the simulator
# assumes 256 (sim/line.py). 64 is a conservative bound that every real command fits
# in: the longest name, tilt_angle_from_home, with the longest value format_number
# writes (20 characters) makes 45. A twm has six values: within their bounds and
# written with all nine decimals it could make 73 characters (`set twm -0.509999999
# -0.249999999 -1.999999999 0.399999999 -0.159999999 0`), and such a one is refused.
# The console's own fit: teleop's at most 58 (its speed has four decimals, its vgr is
# +-1), the executor's, at four decimals, at most 49 (tests/robot/test_twm.py); and
# robot/twm.py sends separate sets rather than a longer twm.
MAX_LINE_CHARS = 64

# The only bare command the board knows (A.4.10): the head's homing sequence.
BARE_COMMANDS = frozenset({"home"})

# Every setting the board takes (A.4; wire-facts: the encoders and height stalk of
# later firmware). Each has a `get` that reads it back (A.4).
SETTINGS = frozenset({
    "v", "a", "r", "p", "mode", "undock", "tilt_angle_from_home", "vg", "vgr", "cdp", "h",
    "enc0", "enc1", TWM,
})  # fmt: skip
# What the board can read: its settings, and its state (A.4.5-A.4.21; wire-facts: the
# charger; Giraff-X answers `get twm` with a list).
READINGS = SETTINGS | {
    "cang", "cdis", "gvr", "cvg", "tilt_homing_state", "but0", "but1", "dial",
    "button_data", "bulk_data", "charger_data",
}  # fmt: skip

# The board's own undock queues a back-out and then a 180-degree turn in place (A.4.9):
# pi * 0.2495 m of wheel travel that nothing but a live console could stop.
REFUSED_SETTINGS = {
    "undock": (
        f"the board's undock queues a 180-degree turn in place ({math.pi * TURN_RADIUS_M:.3f} "
        "m of wheel travel, A.4.9) that a dead console could not stop; the console's "
        "undock streams it in bounded steps instead"
    ),
}

# |vg| must stay below this: at 0.51 the thesis saw the board misbehave (§3.2.1.4).
GEAR_RATIO_LIMIT = 0.51
# The steepest ramp of the gear ratio, per metre: from straight to the top ratio in a
# quarter of a metre. A steeper ramp is a jump of the ratio, which jerks and stresses
# the hardware (A.2.3). Teleop ramps at 1.0 (DEF_VGACCEL, B.2), missions at up to 2.0
# (motion/executor.py GEAR_RATE_RANGE).
MAX_GEAR_RATE = 2.0
# The styles of A.4.2 are r = 0 (rotate), 0 < r <= 50 (straight) and r > 50 (curved);
# the thesis sends only 0 and 1000 (B.2 GiraffMotor). r < 0 is undocumented.
MAX_STYLE = 1000.0
MAX_STRAIGHT_STYLE = 50.0
# The resolution of a value on the wire (codec.format_number).
_WIRE_STEP = 10.0**-DECIMALS
# Later boards' `mode 2`, in which `vg` is an angular velocity (wire-facts); the modes
# the guard lets a move run in.
VELOCITY_MODE = 2
MODES = (0, VELOCITY_MODE)
# The fastest turn on the spot in mode 2, degrees per second: each wheel then goes
# radians(90) * 0.2495 = 0.39 m/s, within the console's top speed of 0.4 m/s.
MAX_SPIN_DEG_S = 90.0


@dataclass(frozen=True)
class Bound:
    """The values a setting may take, and why."""

    low: float
    high: float
    why: str
    unit: str = ""
    open_low: bool = False
    open_high: bool = False
    whole: bool = False
    # The only values it may take, when they are not a range.
    only: tuple[float, ...] = ()

    def admits(self, value: float) -> bool:
        """True if `value`, as it goes on the wire, is within the bounds. Values go out
        rounded to DECIMALS places, so a closed bound is met to within that."""
        if self.only:
            return value in self.only
        if self.whole and value != int(value):
            return False
        above = value > self.low if self.open_low else value >= self.low - _WIRE_STEP
        below = value < self.high if self.open_high else value <= self.high + _WIRE_STEP
        return above and below

    def __str__(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        if self.only:
            return " or ".join(f"{value:.4g}" for value in self.only) + unit
        if self.low == self.high:
            return f"{self.low:.4g}{unit}"
        low, high = "(" if self.open_low else "[", ")" if self.open_high else "]"
        return f"in {low}{self.low:.4g}, {self.high:.4g}{high}{unit}"


def setting_bounds(limits: DriveLimits, speed: float | None = None,
                   mode: float = 0) -> dict[str, Bound]:  # fmt: skip
    """Every setting the guard lets through, with its bounds and the reason for them.

    `p` and twm are not here: how far a move may reach depends on the style, and a twm
    is a move (see check_command).
    `speed`, when known, bounds how fast the robot may be going as a move starts.
    `mode`: the board's, which says what `vg` is (a gear ratio, or in mode 2 degrees
    per second).
    """
    gentlest = limits.min_accel if speed is None else braking_accel(speed, limits.runaway)
    if mode == VELOCITY_MODE:
        vg = Bound(-MAX_SPIN_DEG_S, MAX_SPIN_DEG_S, "in mode 2 vg is degrees per second "
                   "(wire-facts); turning on the spot faster, the wheels would outrun the "
                   "console's top speed", "degrees/s")  # fmt: skip
    else:
        vg = Bound(-GEAR_RATIO_LIMIT, GEAR_RATIO_LIMIT, "|vg| must stay below 0.51 "
                   "(§3.2.1.4)", open_low=True, open_high=True)  # fmt: skip
    return {
        "v": Bound(0, limits.max_speed, "the console's top speed (design.md)", "m/s"),
        "a": Bound(gentlest, limits.accel, "it must stop the robot within the runaway "
                   "limit from the fastest it may be going, and no harder than the "
                   "console's own acceleration (B.2 DEF_ACCEL)", "m/s^2",
                   open_low=gentlest <= _WIRE_STEP),  # never a = 0 (wire-facts)
        "vg": vg,
        "vgr": Bound(-MAX_GEAR_RATE, MAX_GEAR_RATE, "a steeper ramp of the gear ratio is "
                     "a jump, which jerks the robot (A.2.3)", "per metre"),
        "cdp": Bound(-limits.reach, limits.reach, "it is a point within the move "
                     "(A.4.15), and no move reaches further than the console's reach", "m"),
        "r": Bound(0, MAX_STYLE, "the movement styles of A.4.2: 0 rotates, up to 50 "
                   "drives straight, above 50 curves"),
        "mode": Bound(0, VELOCITY_MODE, "commands drive in relative, unbuffered mode 0, "
                      "or in later boards' mode 2, relative too (wire-facts): absolute "
                      "targets can lie anywhere, and buffered moves add up (A.4.8)",
                      only=MODES),
        "tilt_angle_from_home": Bound(0.087, 2.094, "the head's travel from home "
                                      "(wire-facts, Head)", "rad"),
        "h": Bound(0, 1000, "the height stalk's range (wire-facts)", whole=True),
        "enc0": Bound(0, 0, "drivers only zero the wheel encoders (wire-facts)", whole=True),
        "enc1": Bound(0, 0, "drivers only zero the wheel encoders (wire-facts)", whole=True),
    }  # fmt: skip


def check_line(command: Command) -> None:
    """Raise CommandError for a command longer than the board's line (MAX_LINE_CHARS)."""
    length = len(command.text)
    if length > MAX_LINE_CHARS:
        raise CommandError(
            f"a {length}-character line is longer than the board's line of "
            f"{MAX_LINE_CHARS} characters"
        )


def check_command(command: Command, limits: DriveLimits, board: Mapping[str, str],
                  speed: float | None = None) -> None:  # fmt: skip
    """Raise CommandError, saying why, for a command outside the limits.

    `board` is what the board holds for its next move, as sent on the wire. A move
    (`set p`) is only allowed when everything it will use is known and within the
    limits; in rotation (r = 0) `p` is in degrees (A.2.2). `speed`, when known, bounds
    how fast the robot (its wheels, when rotating) may go as the move starts, in m/s.
    """
    check_line(command)
    name = command.name
    if command.kind == "get":
        if name not in READINGS:
            raise CommandError(f"the board has no reading called {name!r}")
        return
    if command.kind == "command":
        if name not in BARE_COMMANDS:
            raise CommandError(
                f"{name!r} is not a command the board knows; its only bare command is home (A.4.10)"
            )
        return
    if name in REFUSED_SETTINGS:
        raise CommandError(f"set {name} is refused: {REFUSED_SETTINGS[name]}")
    if name == TWM:
        _check_twm(command, limits, board, speed)
        return
    # The value as it goes on the wire, which is what the board will act on.
    value = float(command.text.split()[2])
    if name == "p":
        _check_move(value, limits, board, speed)
    else:
        _check_setting(name, value, limits, speed, _held_mode(board))


def clamp_command(command: Command, limits: DriveLimits, board: Mapping[str, str]) -> Command:
    """`command` with its values brought within their bounds where that can only make a
    move shorter, slower or surer to stop, for a program that cannot read the guard's reasons
    (the virtual port: the deployed drivers never read a `set`'s reply, wire-facts):
    a speed, a turn rate or a gear ratio's ramp down to its limit; an acceleration down
    to the console's, or one too gentle to stop the robot within the runaway limit up to
    the gentlest that does (harder than asked, never harder than the console's own); a
    move's target down to the reach for what the board holds. A negative speed or
    acceleration, anything else, and a move that cannot go at all, is returned unchanged
    for `check_command` to refuse with its reason."""
    if command.kind != "set":
        return command
    mode = _held_mode(board)
    if command.name == TWM:
        *carried, end = command.values
        if end != 0 or mode == VELOCITY_MODE:
            return command
        values = [_clamped(name, float(value), limits, mode)
                  for name, value in zip(TWM_SETTINGS[:-1], carried[:-1], strict=True)]  # fmt: skip
        curve = {**board, **dict(zip(TWM_SETTINGS[:-1], map(format_number, values), strict=True)),
                 "r": format_number(MAX_STYLE)}  # fmt: skip
        target = _clamped_target(float(carried[-1]), limits, curve)
        return Command("set", TWM, (*values, target, end))
    if command.name == "p":
        return Command("set", "p", _clamped_target(float(command.values[0]), limits, board))
    if command.name in CLAMPED:
        return Command("set", command.name, _clamped(command.name, float(command.values[0]),
                                                     limits, mode))  # fmt: skip
    return command


# The settings whose values `clamp_command` brings within their bounds.
CLAMPED = frozenset({"v", "a", "vg", "vgr", "cdp"})


def _clamped(name: str, value: float, limits: DriveLimits, mode: float) -> float:
    """`value` within `name`'s bounds (inside an open bound by one step on the wire);
    unchanged below a bound of zero or more, which only a value of another kind is (a
    negative speed or acceleration: refused, not made into a stop or a turn)."""
    if name == "vg" and mode != VELOCITY_MODE:
        # A gear ratio: no steeper than the console's own curves (below 0.51).
        return max(-limits.max_gear, min(limits.max_gear, value))
    bound = setting_bounds(limits, None, mode)[name]
    low = bound.low + (_WIRE_STEP if bound.open_low else 0.0)
    high = bound.high - (_WIRE_STEP if bound.open_high else 0.0)
    if value < low and (bound.low < 0 or value > 0):
        return low
    return min(high, value)


def _clamped_target(target: float, limits: DriveLimits, board: Mapping[str, str]) -> float:
    """`target` no further than the reach for what the board holds (unchanged if a move
    cannot go with it: check_command says why)."""
    try:
        per_unit, _ = _reach_per_unit(limits, board, None)
    except CommandError:
        return target
    # Rounded down on the wire's resolution, so that the value sent is within the reach.
    furthest = round(math.floor(limits.reach / per_unit / _WIRE_STEP + 1e-6) * _WIRE_STEP,
                     DECIMALS)  # fmt: skip
    return math.copysign(min(abs(target), furthest), target)


def braking_accel(speed: float, runaway: float) -> float:
    """The gentlest acceleration that stops the robot from `speed` within `runaway`."""
    return speed * speed / (2 * runaway)


def _held_mode(board: Mapping[str, str]) -> float:
    """The board's mode as it says what `vg` is: 0 when unknown (a gear ratio, the
    tighter bound)."""
    try:
        return float(board.get("mode", "0"))
    except ValueError:
        return 0.0


def _check_setting(name: str, value: float, limits: DriveLimits, speed: float | None,
                   mode: float = 0) -> None:  # fmt: skip
    bound = setting_bounds(limits, speed, mode).get(name)
    if bound is None:
        known = ", ".join(sorted(SETTINGS - REFUSED_SETTINGS.keys()))
        raise CommandError(f"the board has no setting called {name!r} (settings: {known})")
    if not bound.admits(value):
        raise CommandError(f"{name} must be {bound}: {bound.why}")


def _check_twm(command: Command, limits: DriveLimits, board: Mapping[str, str],
               speed: float | None) -> None:  # fmt: skip
    """A twm sets vg, cdp, vgr and v and moves by p (wire-facts): each value within its
    own setting's bounds, then the move as `set p` would be, with the board's settings
    overlaid by the twm's, as a curve whatever the board's r."""
    # The values as they go on the wire, which is what the board will act on.
    *carried, end = (float(word) for word in command.text.split()[2:])
    if end != 0:
        raise CommandError(
            f"a twm ends in 0 (`set twm {' '.join(TWM_SETTINGS)} 0`, wire-facts); what "
            "another value would do is not documented"
        )
    if _held_mode(board) == VELOCITY_MODE:
        raise CommandError("a twm in mode 2 is not documented (wire-facts); set mode 0 first")
    for name, value in zip(TWM_SETTINGS[:-1], carried[:-1], strict=True):
        _check_setting(name, value, limits, speed)
    # A curve whatever the board's r (wire-facts): checked as one, on the outer wheel.
    curve = {**board, **command.settings, "r": format_number(MAX_STYLE)}
    _check_move(carried[-1], limits, curve, speed)


def _check_move(target: float, limits: DriveLimits, board: Mapping[str, str],
                speed: float | None) -> None:  # fmt: skip
    """A move uses mode, v, a and vg as the board holds them, and r but in mode 2; each
    must be known and within its bounds, and the target within the runaway limit."""
    per_unit, unit = _reach_per_unit(limits, board, speed)
    if abs(target) * per_unit > limits.reach + _WIRE_STEP:
        raise CommandError(f"p beyond {unit}; a dead console would let the robot run that far")


def _reach_per_unit(limits: DriveLimits, board: Mapping[str, str],
                    speed: float | None) -> tuple[float, str]:  # fmt: skip
    """How far the farthest wheel goes for each unit of a move's `p` with what the board
    holds, and the reach in words; CommandError if a move cannot go with it."""
    velocity = "mode" in board and _held_mode(board) == VELOCITY_MODE
    held: dict[str, float] = {}
    for needed in ("mode", "v", "a", "vg") if velocity else ("r", "mode", "v", "a", "vg"):
        if needed not in board:
            unread = " (its writable bits cannot be read back, A.4.8)" if needed == "mode" else ""
            raise CommandError(f"the board's {needed} is unknown{unread}; set it first")
        try:
            held[needed] = float(board[needed])
        except ValueError:
            raise CommandError(f"the board's {needed} is not a number: {board[needed]!r}") from None
        _check_setting(needed, held[needed], limits, speed, held.get("mode", 0.0))
    if velocity:
        return _velocity_reach_per_metre(held["v"], held["vg"], limits)
    if not held["v"] > 0:
        raise CommandError("v must be above 0 for a move in mode 0: a move at zero speed "
                           "cannot be planned")  # fmt: skip
    if held["r"] == 0:
        # Turning on the spot `p` is degrees, v and a the wheels' (A.2.2).
        return 1 / TURN_FACTOR_DEG_PER_M, f"{limits.reach * TURN_FACTOR_DEG_PER_M:.0f} degrees"
    # In a curve (r > 50) the outer wheel goes 1 + |vg| times as far as the middle (A.2.3).
    outer = 1 + abs(held["vg"]) if held["r"] > MAX_STRAIGHT_STYLE else 1.0
    return outer, f"{limits.reach} m" + (" on the outer wheel" if outer > 1 else "")


def _velocity_reach_per_metre(v: float, vg: float, limits: DriveLimits) -> tuple[float, str]:
    """A mode 2 move: with v = 0 it turns on the spot at vg by |p| metres of each wheel;
    else it curves by the gear ratio radians(vg) / v * 0.2495 (wire-facts, "Quirks"),
    which must stay below the thesis's 0.51 (§3.2.1.4), its outer wheel going 1 + that
    times as far."""
    if v == 0:
        if vg == 0:
            raise CommandError("in mode 2 a move needs v above 0, or vg to turn on the spot")
        return 1.0, f"{limits.reach} m of each wheel"
    gear = math.radians(abs(vg)) / v * TURN_RADIUS_M
    if not gear < GEAR_RATIO_LIMIT:
        raise CommandError(
            f"in mode 2, {abs(vg):g} degrees/s at {v:g} m/s is a gear ratio of {gear:.2f}; "
            f"it must stay below {GEAR_RATIO_LIMIT} (§3.2.1.4)"
        )
    return 1 + gear, f"{limits.reach} m" + (" on the outer wheel" if gear > 0 else "")
