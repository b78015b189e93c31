"""What every VDA 5050 message starts with (§6.2): a headerId counted per topic, the
time, the version, and who sends it; and the message as bytes on the wire."""

from __future__ import annotations

import datetime
import itertools
import json
from collections.abc import Callable
from typing import Any

from giraff_console.fleet.topics import VERSION, Topic, VehicleId


def timestamp(now: datetime.datetime | None = None) -> str:
    """ISO 8601 in UTC with milliseconds and a Z, as the standard's examples write it."""
    now = (now or datetime.datetime.now(datetime.UTC)).astimezone(datetime.UTC)
    return now.strftime("%Y-%m-%dT%H:%M:%S.") + f"{now.microsecond // 1000:03d}Z"


class Headers:
    """The headers of the messages on one vehicle's topics (its own, or a master's to
    it): each topic's headerId goes up by one with each message sent (§6.2), whatever
    becomes of it. `clock`: the time, in UTC (a test's fixed one)."""

    def __init__(self, vehicle: VehicleId,
                 clock: Callable[[], datetime.datetime] | None = None) -> None:  # fmt: skip
        self.vehicle = vehicle
        self.clock = clock
        self._counters = {kind: itertools.count() for kind in Topic}

    def stamp(self, kind: Topic, body: dict[str, Any]) -> dict[str, Any]:
        return {
            "headerId": next(self._counters[kind]),
            "timestamp": timestamp(self.clock() if self.clock is not None else None),
            "version": VERSION,
            "manufacturer": self.vehicle.manufacturer,
            "serialNumber": self.vehicle.serial_number,
            **body,
        }


def encode(message: dict[str, Any]) -> bytes:
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode()
