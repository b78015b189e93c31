"""The three ways a Giraff board tells how far its wheels went (wire-facts, "Later firmware").

- `totals`: `imdl`/`imdr` as the thesis's board (and our simulator's `thesis` profile)
  reports them, metres turned since power-up; a step is the difference of two reads.
- `increments`: `imdl`/`imdr` as later boards report them, metres turned since the
  previous `get bulk_data`, which resets them ("incremental move distance" in the ROS 1
  driver's header; the ROS 2 driver adds them up on every read). A step is the value as
  it comes, so every read of bulk_data, whoever asked for it, must reach the odometry.
- `encoders`: `enc0` (left) and `enc1` (right), 16-bit counters at 2002.0594 counts per
  metre that wrap at 65,536; a step takes the shorter way round between two reads.

Each gives the left and right wheels' travel between two samples (MotorState), or None
when the step cannot be believed. Which one a board needs is found by the probe
(link/board_probe.py) and checked against `cdis` during the first motion
(odometer_check.py).
"""

from __future__ import annotations

import enum
from abc import ABC, abstractmethod
from typing import ClassVar

from giraff_console.link.board_probe import BoardFeatures
from giraff_console.link.motor_state import MotorState

# Faster than a Giraff wheel ever turns, and a margin for the first sample's timing.
MAX_WHEEL_SPEED = 2.0
JUMP_MARGIN_M = 0.05
# The encoders' scale and range (wire-facts: the drivers' constants).
COUNTS_PER_METRE = 2002.0594
ENCODER_WRAP = 65_536


class Reading(enum.StrEnum):
    """How the wheels' travel is read: the names of the `[board] odometers` setting."""

    TOTALS = "totals"
    INCREMENTS = "increments"
    ENCODERS = "encoders"


AUTO = "auto"
# What `[board] odometers` may say.
CHOICES = (AUTO, *(reading.value for reading in Reading))

Travel = tuple[float, float]


class WheelOdometers(ABC):
    """One reading of the wheels: their travel from one sample to the next."""

    reading: ClassVar[Reading]
    # Whether a read of bulk_data resets what this reading counts: then a read the
    # console did not poll itself (a typed `get bulk_data`, the stop's own poll) carries
    # travel that must not be lost.
    consumed_by_reads: ClassVar[bool] = False
    # What a sample lacks when it cannot be used, for the message.
    needs: ClassVar[str]

    @abstractmethod
    def usable(self, state: MotorState) -> bool:
        """Whether `state` carries what this reading needs."""

    @abstractmethod
    def _travel(self, last: MotorState, state: MotorState) -> Travel:
        """The left and right wheels' travel (m) from `last` to `state`."""

    def travel(self, last: MotorState, state: MotorState) -> Travel | None:
        """The wheels' travel from `last` to `state`; None when it is further than any
        wheel can go in the time between them: counters that restarted (a power cycle)
        or garbage. Both states must be `usable`."""
        return _plausible(self._travel(last, state), state.received_at - last.received_at)

    def travel_alone(self, state: MotorState, elapsed: float) -> Travel | None:
        """The wheels' travel that `state` alone tells, for a reading whose reads consume
        what it counts (increments): since the previous read of bulk_data, `elapsed`
        seconds before. None for the other readings, whose sample alone is only a
        reference, and for travel further than the wheels can go in that time."""
        return None


def _plausible(travel: Travel, elapsed: float) -> Travel | None:
    left, right = travel
    if max(abs(left), abs(right)) > MAX_WHEEL_SPEED * max(0.0, elapsed) + JUMP_MARGIN_M:
        return None
    return left, right


class TotalOdometers(WheelOdometers):
    """`imdl`/`imdr` as totals since power-up: differenced."""

    reading = Reading.TOTALS
    needs = "wheel distances (imdl, imdr)"

    def usable(self, state: MotorState) -> bool:
        return state.imdl is not None and state.imdr is not None

    def _travel(self, last: MotorState, state: MotorState) -> Travel:
        assert state.imdl is not None and state.imdr is not None
        assert last.imdl is not None and last.imdr is not None
        return state.imdl - last.imdl, state.imdr - last.imdr


class IncrementalOdometers(WheelOdometers):
    """`imdl`/`imdr` as increments since the previous read: taken as they come."""

    reading = Reading.INCREMENTS
    consumed_by_reads = True
    needs = "wheel distances (imdl, imdr)"

    def usable(self, state: MotorState) -> bool:
        return state.imdl is not None and state.imdr is not None

    def _travel(self, last: MotorState, state: MotorState) -> Travel:
        assert state.imdl is not None and state.imdr is not None
        return state.imdl, state.imdr

    def travel_alone(self, state: MotorState, elapsed: float) -> Travel | None:
        return _plausible(self._travel(state, state), elapsed)


class Encoders(WheelOdometers):
    """`enc0`/`enc1`: 16-bit counts, differenced the shorter way round a wrap."""

    reading = Reading.ENCODERS
    needs = "encoder counts (enc0, enc1)"

    def usable(self, state: MotorState) -> bool:
        return state.enc0 is not None and state.enc1 is not None

    def _travel(self, last: MotorState, state: MotorState) -> Travel:
        assert state.enc0 is not None and state.enc1 is not None
        assert last.enc0 is not None and last.enc1 is not None
        return counts_travel(last.enc0, state.enc0), counts_travel(last.enc1, state.enc1)


def counts_travel(last: int, now: int) -> float:
    """Metres between two encoder counts, the shorter way round the 16-bit wrap: at
    0.5 mm a count the counter wraps every 32.7 m, so two reads a tick apart are never
    half a wrap apart."""
    half = ENCODER_WRAP // 2
    counts = (now - last + half) % ENCODER_WRAP - half
    return counts / COUNTS_PER_METRE


_READINGS: dict[Reading, type[WheelOdometers]] = {
    Reading.TOTALS: TotalOdometers,
    Reading.INCREMENTS: IncrementalOdometers,
    Reading.ENCODERS: Encoders,
}


def odometers_for(reading: Reading | str) -> WheelOdometers:
    """The odometers for a reading's name; ValueError for another name."""
    return _READINGS[Reading(reading)]()


def firmware_reading(features: BoardFeatures) -> Reading:
    """What `auto` reads: increments on later firmware (both drivers add imdl/imdr up),
    totals on the thesis's board."""
    return Reading.INCREMENTS if features.later_firmware else Reading.TOTALS


def choose_reading(setting: str, features: BoardFeatures) -> tuple[Reading, str | None]:
    """The reading for the `[board] odometers` setting on a board with `features`, and a
    message when the setting cannot be followed (encoders on a board without them)."""
    if setting == AUTO:
        return firmware_reading(features), None
    reading = Reading(setting)
    if reading is Reading.ENCODERS and not features.encoders:
        fallback = firmware_reading(features)
        return fallback, (
            "odometry: the settings ask for the wheel encoders, but this board has none "
            f"(get enc0: Unknown name); reading imdl/imdr as {fallback} instead"
        )
    return reading, None
