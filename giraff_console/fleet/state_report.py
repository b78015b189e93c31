"""The vehicle's `state` and `visualization` (VDA 5050 2.1 §6.10, §6.16), from what the
robot service says and what the fleet link keeps of the order: pure functions, so that
the tests read them without a broker."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from giraff_console.fleet.orders import ErrorType, Node
from giraff_console.fleet.vocabulary import ActionStatus, ErrorLevel, OperatingMode
from giraff_console.robot.telemetry import LinkState, Telemetry

# The position's standard deviation (metres) at which the localization score reaches
# 0: a robot that may be half a metre off cannot be trusted to find a doorway.
SCORE_ZERO_SIGMA_M = 0.5


@dataclass(frozen=True)
class Error:
    kind: ErrorType
    level: ErrorLevel
    description: str
    references: tuple[tuple[str, str], ...] = ()

    def as_json(self) -> dict[str, Any]:
        return {
            "errorType": self.kind.value,
            "errorLevel": self.level.value,
            "errorDescription": self.description[:500],
            "errorReferences": [
                {"referenceKey": key, "referenceValue": value[:128]}
                for key, value in self.references
            ],
        }


@dataclass(frozen=True)
class ActionState:
    action_id: str
    action_type: str
    status: ActionStatus
    result: str = ""

    def as_json(self) -> dict[str, Any]:
        state: dict[str, Any] = {"actionId": self.action_id, "actionType": self.action_type,
                                 "actionStatus": self.status.value}  # fmt: skip
        if self.result:
            state["resultDescription"] = self.result[:200]
        return state


@dataclass(frozen=True)
class OrderProgress:
    """What is left of the order under way, or of the last one."""

    order_id: str = ""
    update_id: int = 0
    last_node: str = ""
    last_sequence: int = 0
    nodes: tuple[Node, ...] = ()  # not yet reached
    edges: tuple[tuple[str, int, bool], ...] = ()  # (edgeId, sequenceId, released)


@dataclass(frozen=True)
class VehicleFacts:
    """Everything one `state` says."""

    telemetry: Telemetry | None
    map_id: str
    room: str | None  # where the robot stands, when no order says otherwise
    progress: OrderProgress
    mode: OperatingMode
    paused: bool
    driving: bool
    errors: tuple[Error, ...] = ()
    actions: tuple[ActionState, ...] = ()
    information: tuple[str, ...] = ()


def state_body(facts: VehicleFacts) -> dict[str, Any]:
    progress, telemetry = facts.progress, facts.telemetry
    # Where it stands when no order drives it (wherever it was driven since the last);
    # during an order, the last node reached.
    last_node = facts.room if facts.room is not None else progress.last_node
    errors = list(facts.errors)
    if telemetry is None or telemetry.link is LinkState.LOST:
        errors.append(Error(ErrorType.BOARD, ErrorLevel.FATAL, "no link to the motor board"))
    body: dict[str, Any] = {
        "orderId": progress.order_id,
        "orderUpdateId": progress.update_id,
        "lastNodeId": last_node,
        "lastNodeSequenceId": progress.last_sequence,
        "nodeStates": [
            {"nodeId": node.node_id, "sequenceId": node.sequence_id, "released": node.released}
            for node in progress.nodes
        ],
        "edgeStates": [
            {"edgeId": edge_id, "sequenceId": sequence, "released": released}
            for edge_id, sequence, released in progress.edges
        ],
        "driving": facts.driving,
        "paused": facts.paused,
        "newBaseRequest": False,
        "operatingMode": facts.mode.value,
        "actionStates": [action.as_json() for action in facts.actions],
        "batteryState": _battery(telemetry),
        "errors": [error.as_json() for error in errors],
        "information": [
            {"infoType": "mission", "infoLevel": "INFO", "infoDescription": text[:200]}
            for text in facts.information
        ],
        "safetyState": {"eStop": _estop(telemetry), "fieldViolation": False},
    }
    position = _position(facts)
    if position is not None:
        body["agvPosition"] = position
        body["velocity"] = _velocity(telemetry)
    return body


def visualization_body(facts: VehicleFacts) -> dict[str, Any]:
    body: dict[str, Any] = {}
    position = _position(facts)
    if position is not None:
        body["agvPosition"] = position
        body["velocity"] = _velocity(facts.telemetry)
    return body


def _position(facts: VehicleFacts) -> dict[str, Any] | None:
    telemetry = facts.telemetry
    if telemetry is None:
        return None
    pose, estimate = telemetry.pose, telemetry.estimate
    position: dict[str, Any] = {
        "x": round(pose.x, 4), "y": round(pose.y, 4), "theta": round(pose.heading, 5),
        "mapId": facts.map_id,
        # Known: found by a marker, or placed (by the operator, or the dock the simulator
        # starts on); not a pose only assumed (a daemon restarted: robot/localisation.py).
        "positionInitialized": estimate is not None and (estimate.found or estimate.basis.verified),
    }  # fmt: skip
    if estimate is not None:
        score = 1.0 - min(1.0, estimate.sigma_m / SCORE_ZERO_SIGMA_M)
        position["localizationScore"] = round(max(0.0, score), 3)
        position["deviationRange"] = round(estimate.sigma_m, 3)
    return position


def _velocity(telemetry: Telemetry | None) -> dict[str, float]:
    state = telemetry.state if telemetry is not None else None
    speed = state.speed if state is not None and state.speed is not None else 0.0
    return {"vx": round(speed, 3), "vy": 0.0}


def _battery(telemetry: Telemetry | None) -> dict[str, Any]:
    battery = telemetry.battery if telemetry is not None else None
    if battery is None:
        # The thesis's board reports no battery: the standard wants a figure, and 100
        # with no charging is what a fleet manager reads as "nothing to do about it".
        return {"batteryCharge": 100.0, "charging": False}
    charge = battery.percent if battery.percent is not None else 100.0
    state: dict[str, Any] = {"batteryCharge": round(charge, 1), "charging": battery.charging}
    if battery.voltage is not None:
        state["batteryVoltage"] = round(battery.voltage, 2)
    return state


def _estop(telemetry: Telemetry | None) -> str:
    state = telemetry.state if telemetry is not None else None
    # The Giraff's stop button is a switch a person releases (A.2.1): MANUAL.
    return "MANUAL" if state is not None and state.estop else "NONE"
