"""The robot's battery and the dock's charger, as a later board reports them.

Later boards answer `get charger_data` with one of six readings in turn (wire-facts,
"Later firmware"): battery voltage, current and temperature, dock voltage and current,
and the watt-seconds drawn since the battery was full. One driver takes 327,360 W·s
from full to empty, which is the capacity here. Everything else about the battery (its
loads, its charging powers, its voltage curve) is an assumption of a plausible size,
listed in docs/simulator.md: no source gives the real figures.
"""

from __future__ import annotations

from giraff_console.protocol.charger import ChargeStatus

# Watt-seconds from full to empty: the c = -327,360 of one driver's |(c - W)/c|.
CAPACITY_WS = 327_360.0
# What the robot draws standing still (the board, the head, the computer): assumption.
IDLE_W = 12.0
# Energy per metre of wheel travel: assumption.
MOTION_J_PER_M = 150.0
# The charger charges fast up to this level, then trickles to full: assumption.
FAST_CHARGE_W = 60.0
FAST_CHARGE_UNTIL = 0.9
TRICKLE_CHARGE_W = 10.0
# A lead pack of about 24 V nominal: empty 22.0 V, full 25.6 V, 0.8 V more on charge.
EMPTY_VOLTS = 22.0
FULL_SWING_VOLTS = 3.6
CHARGING_LIFT_VOLTS = 0.8
DOCK_VOLTS = 28.0
TEMPERATURE_C = 25.0


class Battery:
    """Charge over time on the board's clock: drained by time and travel, charged docked."""

    def __init__(self, level: float, now: float) -> None:
        if not 0.0 <= level <= 1.0:
            raise ValueError("the battery level must be between 0 and 1")
        self.drawn_ws = (1.0 - level) * CAPACITY_WS
        self.docked = False
        self._wheel_speed = 0.0
        self._last = now

    @property
    def level(self) -> float:
        """Charge left, 0 (empty) to 1 (full)."""
        return 1.0 - self.drawn_ws / CAPACITY_WS

    def update(self, now: float, travel: float, docked: bool, wheel_speed: float) -> None:
        """Account for the time since the last update, `travel` metres of wheel travel in
        it, and the robot standing on the dock (or not) now at `wheel_speed` m/s.

        The dock is judged where the robot is now: a robot read rarely while it drives
        onto the dock is counted as docked a little early, which no reading shows.
        """
        elapsed = max(0.0, now - self._last)
        self._last = max(now, self._last)
        if docked:
            self._charge(elapsed)
        else:
            drawn = self.drawn_ws + IDLE_W * elapsed + MOTION_J_PER_M * travel
            # An empty battery stays empty; the simulated robot does not brown out.
            self.drawn_ws = min(CAPACITY_WS, drawn)
        self.docked = docked
        self._wheel_speed = wheel_speed

    def _charge(self, seconds: float) -> None:
        fast_left = self.drawn_ws - (1.0 - FAST_CHARGE_UNTIL) * CAPACITY_WS
        if fast_left > 0:
            fast = min(seconds, fast_left / FAST_CHARGE_W)
            self.drawn_ws -= FAST_CHARGE_W * fast
            seconds -= fast
        self.drawn_ws = max(0.0, self.drawn_ws - TRICKLE_CHARGE_W * seconds)

    @property
    def _fast(self) -> bool:
        # A millijoule of slack: the fast charge ends exactly at 90 %, give or take rounding.
        return self.drawn_ws > (1.0 - FAST_CHARGE_UNTIL) * CAPACITY_WS + 1e-3

    @property
    def status(self) -> ChargeStatus:
        if not self.docked:
            return ChargeStatus.NOT_DOCKED
        return ChargeStatus.FAST_CHARGING if self._fast else ChargeStatus.TRICKLE_CHARGING

    @property
    def power(self) -> float:
        """Watts into the battery now: negative while it discharges."""
        if self.docked:
            if self._fast:
                return FAST_CHARGE_W
            return TRICKLE_CHARGE_W if self.drawn_ws > 0 else 0.0
        return -(IDLE_W + MOTION_J_PER_M * self._wheel_speed)

    @property
    def voltage(self) -> float:
        lift = CHARGING_LIFT_VOLTS if self.power > 0 else 0.0
        return EMPTY_VOLTS + FULL_SWING_VOLTS * self.level + lift

    @property
    def current(self) -> float:
        """Amperes into the battery: negative while discharging (wire-facts `b`)."""
        return self.power / self.voltage

    @property
    def dock_voltage(self) -> float:
        return DOCK_VOLTS if self.docked else 0.0

    @property
    def dock_current(self) -> float:
        """The dock carries the robot's load as well as the charge."""
        if not self.docked:
            return 0.0
        load = IDLE_W + MOTION_J_PER_M * self._wheel_speed
        return (self.power + load) / DOCK_VOLTS

    def reading(self, parameter: str) -> float:
        """The value of one charger parameter (`B`, `b`, `t`, `D`, `d`, `W`)."""
        values = {
            "B": lambda: self.voltage,
            "b": lambda: self.current,
            "t": lambda: TEMPERATURE_C,
            "D": lambda: self.dock_voltage,
            "d": lambda: self.dock_current,
            # Drawn watt-seconds count down from 0 (full), as the driver's formula needs.
            # Sent as a float (`W:F#`) like the rest: protocol.charger.format_charger.
            "W": lambda: 0.0 - self.drawn_ws,  # 0.0, not -0.0, when full
        }
        return values[parameter]()
