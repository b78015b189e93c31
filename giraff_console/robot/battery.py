"""The battery as the charger reports it, one parameter per read (wire-facts "Later firmware").

A later board's `get charger_data` carries the charger's status and one of six
parameters, in turn (protocol/charger.py). The gauge keeps the latest of each, so after
six reads it knows the whole picture; until then what it has not heard is None.
"""

from __future__ import annotations

from dataclasses import dataclass

from giraff_console.protocol.charger import ChargerReading, ChargeStatus

# Watt-seconds from full to empty: one driver takes the level as |(c - W) / c| with
# c = -327,360 W·s, W being what has been drawn (0 = full, negative as drawn).
FULL_TO_EMPTY_WS = 327_360.0

_CHARGING = frozenset({ChargeStatus.FAST_CHARGING, ChargeStatus.TRICKLE_CHARGING})


def percent_left(drawn_ws: float) -> float:
    """The charge left, 0 to 100, from the watt-seconds drawn (`W`, 0 or negative).

    The driver's formula 1 - W/c, without its absolute value: the two agree between full
    and empty, but beyond empty the absolute value would climb back up and report an
    over-drawn battery as charged. Clamped to 0..100 either way.
    """
    level = 1.0 - drawn_ws / -FULL_TO_EMPTY_WS
    return min(100.0, max(0.0, 100.0 * level))


@dataclass(frozen=True)
class Battery:
    """What is known of the battery; a field not reported yet is None."""

    status: ChargeStatus
    percent: float | None = None
    voltage: float | None = None
    current: float | None = None
    temperature: float | None = None

    @property
    def charging(self) -> bool:
        """Whether the charger is charging it (fast or trickle): the robot is on its dock."""
        return self.status in _CHARGING


class BatteryGauge:
    """The latest of each charger parameter, folded into a Battery."""

    def __init__(self) -> None:
        self._latest: dict[str, float] = {}
        self._battery: Battery | None = None

    @property
    def battery(self) -> Battery | None:
        """The battery as of the last reading; None before the first."""
        return self._battery

    def update(self, reading: ChargerReading) -> Battery:
        """Take in one reading; the status is the reading's, the values the latest of each."""
        self._latest[reading.parameter] = reading.value
        drawn = self._latest.get("W")
        self._battery = Battery(
            status=reading.status,
            percent=None if drawn is None else percent_left(drawn),
            voltage=self._latest.get("B"),
            current=self._latest.get("b"),
            temperature=self._latest.get("t"),
        )
        return self._battery
