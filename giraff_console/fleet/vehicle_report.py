"""What a vehicle says of itself on the broker (VDA 5050 2.1 `connection`, `state` and
`factsheet`), read into typed values for a master control: the decisions and the screen
work on these, never on the message's strings.

Each reader takes a message that has already passed the standard's schema
(fleet/schemas.py), so the fields the schema requires are there and of their type; what
the schema leaves optional is read with a default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from giraff_console.fleet.vocabulary import ConnectionState, ErrorLevel, OperatingMode


@dataclass(frozen=True)
class VehicleError:
    """One of `state.errors`: a refused order, a blocked way, a lost pose."""

    error_type: str
    level: ErrorLevel
    description: str = ""

    def __str__(self) -> str:
        words = f"{self.error_type}: {self.description}" if self.description else self.error_type
        return f"{words} ({self.level.value})"


@dataclass(frozen=True)
class Position:
    """`state.agvPosition`: where the vehicle is on which map (for this robot, the floor
    plan's `name`), in metres and radians."""

    x: float
    y: float
    theta: float
    map_id: str
    initialized: bool
    localization_score: float | None = None


@dataclass(frozen=True)
class VehicleState:
    """The parts of a `state` message the fleet view shows and decides on."""

    header_id: int
    order_id: str
    order_update_id: int
    last_node_id: str  # the room the robot stands in, or last passed
    last_node_sequence_id: int
    nodes_left: tuple[str, ...]  # the order's nodes not yet reached, in order
    driving: bool
    paused: bool
    mode: OperatingMode
    battery_charge: float  # percent
    charging: bool
    errors: tuple[VehicleError, ...]
    position: Position | None
    e_stop: bool  # the safety state's eStop is anything but NONE

    @property
    def target(self) -> str | None:
        """Where the order under way ends; None with no order or once it is done."""
        return self.nodes_left[-1] if self.nodes_left else None

    @property
    def arrived(self) -> bool:
        """The order's last node is reached: nothing left of it, and not driving."""
        return bool(self.order_id) and not self.nodes_left and not self.driving


@dataclass(frozen=True)
class Factsheet:
    """The parts of a `factsheet` that say what the vehicle is and what it can do."""

    series_name: str
    instant_actions: tuple[str, ...]  # the actionTypes it accepts as instant actions


def connection_of(message: dict[str, Any]) -> ConnectionState:
    return ConnectionState(message["connectionState"])


def state_of(message: dict[str, Any]) -> VehicleState:
    """A schema-valid `state` message, read."""
    battery = message["batteryState"]
    safety = message["safetyState"]
    where = message.get("agvPosition")
    position = None
    if where is not None:
        position = Position(float(where["x"]), float(where["y"]), float(where["theta"]),
                            where["mapId"], where["positionInitialized"],
                            where.get("localizationScore"))  # fmt: skip
    # nodeStates holds what remains of the order, released or not (§6.10.5); in the
    # order of their sequence ids, whatever order the vehicle listed them in.
    nodes = sorted(message["nodeStates"], key=lambda node: node["sequenceId"])
    errors = tuple(
        VehicleError(e["errorType"], ErrorLevel(e["errorLevel"]), e.get("errorDescription", ""))
        for e in message["errors"]
    )
    return VehicleState(
        header_id=message["headerId"],
        order_id=message["orderId"],
        order_update_id=message["orderUpdateId"],
        last_node_id=message["lastNodeId"],
        last_node_sequence_id=message["lastNodeSequenceId"],
        nodes_left=tuple(node["nodeId"] for node in nodes),
        driving=message["driving"],
        paused=message.get("paused", False),
        mode=OperatingMode(message["operatingMode"]),
        battery_charge=float(battery["batteryCharge"]),
        charging=battery["charging"],
        errors=errors,
        position=position,
        e_stop=safety["eStop"] != "NONE",
    )


def factsheet_of(message: dict[str, Any]) -> Factsheet:
    """A schema-valid `factsheet` message, read."""
    series = message["typeSpecification"]["seriesName"]
    actions = message["protocolFeatures"]["agvActions"]
    instant = tuple(
        action["actionType"] for action in actions
        if "INSTANT" in action.get("actionScopes", ())
    )  # fmt: skip
    return Factsheet(series, instant)
