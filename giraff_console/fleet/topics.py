"""VDA 5050's topics: `interface/v2/manufacturer/serialNumber/kind` (§6.1 of the
standard).

The version spoken is 2.1.0: the newest of the 2.x line, which the fleet managers our
users run speak (openTCS's and Open-RMF's VDA 5050 adapters), and whose JSON schemas
come with a maintained package (fleet/schemas.py). 2.x is what a deployed master control
expects of a vehicle today; 1.x is obsolete and 3.0 not yet in the adapters.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass

VERSION = "2.1.0"
MAJOR = "v2"
INTERFACE = "uagv"
# A topic level we write: no wildcards, no separators, nothing a broker would read as
# more than one level, and short enough to bound a topic. No colon either: a serial
# number is the robot's user name on the broker, which a password file ends at `:`.
_LEVEL = re.compile(r"[A-Za-z0-9._-]{1,64}\Z")


class Topic(enum.Enum):
    """The six kinds of message; the value is the topic's last level."""

    ORDER = "order"
    INSTANT_ACTIONS = "instantActions"
    STATE = "state"
    VISUALIZATION = "visualization"
    CONNECTION = "connection"
    FACTSHEET = "factsheet"


@dataclass(frozen=True)
class VehicleId:
    """Who a vehicle is on the broker: its manufacturer and serial number, under an
    interface name (`uagv` unless the fleet says otherwise)."""

    manufacturer: str
    serial_number: str
    interface: str = INTERFACE

    def __post_init__(self) -> None:
        for level in (self.interface, self.manufacturer, self.serial_number):
            if not _LEVEL.match(level):
                raise ValueError(f"{level!r} cannot be a topic level: letters, digits and "
                                 "._- only, 1 to 64 of them")  # fmt: skip

    def topic(self, kind: Topic) -> str:
        return f"{self.interface}/{MAJOR}/{self.manufacturer}/{self.serial_number}/{kind.value}"

    @property
    def name(self) -> str:
        return f"{self.manufacturer}/{self.serial_number}"


def every_vehicle(kind: Topic, interface: str = INTERFACE) -> str:
    """The subscription to one kind of message from every vehicle on the broker."""
    return f"{interface}/{MAJOR}/+/+/{kind.value}"


def parse_topic(topic: str) -> tuple[VehicleId, Topic] | None:
    """Whose message and which kind, or None for a topic that is not VDA 5050 2.x."""
    parts = topic.split("/")
    if len(parts) != 5 or parts[1] != MAJOR:
        return None
    try:
        return VehicleId(parts[2], parts[3], parts[0]), Topic(parts[4])
    except ValueError:
        return None
