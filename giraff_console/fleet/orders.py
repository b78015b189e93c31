"""An order, read against the robot's plan (VDA 5050 2.1 §6.6): which rooms it goes
through, in turn, and how much of it is released; or why it cannot be done.

The robot's nodes are its plan's rooms and doors, named as the plan names them; the
fleet manager's map of the building is expected to use those names (`giraff-console
floorplan show` lists them). A node with a position must be where the plan has that
room's point or that door's middle, within NODE_TOLERANCE_M, on the plan's map: a
fleet whose map disagrees with the robot's is told so rather than followed. A door node
only says which door the way takes between the rooms on either side of it; the robot
drives room to room, and a door is passed when the room after it is reached.

Checked here: the order's shape (nodes and edges alternating by sequenceId, each edge
joining its neighbours, released nodes before the horizon), and each node against the
plan. What needs the robot (where it stands, who holds the controls, whether the way is
open now) is the vehicle's to check (fleet/vehicle.py) before any of the order runs.
"""

from __future__ import annotations

import enum
import itertools
import math
from dataclasses import dataclass
from typing import Any

from giraff_console.planning.floorplan import FloorPlan

# How far a node's position may be from the plan's point for it: about a robot's length
# either way, so that a fleet map drawn over the same building by hand still agrees.
NODE_TOLERANCE_M = 0.5
# An order longer than this is refused before any of it is read further (§6.6 leaves
# the length to the vehicle, which says it in its factsheet's protocolLimits).
MAX_NODES = 100
# The longest id (orderId, nodeId, edgeId, actionId, actionType) taken: the factsheet's
# idLen. Ids go back in every state, so a longer one would make every state longer.
MAX_ID = 64


def long_id(message: dict[str, Any]) -> str | None:
    """The first id in an order or instant actions message (already by the schema)
    longer than MAX_ID, shortened, or None."""
    ids = [message.get("orderId", "")]
    for part in ("nodes", "edges", "actions"):
        for item in message.get(part) or ():
            ids += [
                item.get("nodeId", ""),
                item.get("edgeId", ""),
                item.get("actionId", ""),
                item.get("actionType", ""),
            ]
            ids += [a.get("actionId", "") for a in item.get("actions") or ()]
    return next((f"{str(i)[:MAX_ID]}..." for i in ids if len(str(i)) > MAX_ID), None)


class ErrorType(enum.Enum):
    """The errorType of what the vehicle reports in `state` (VDA 5050 2.1 §6.10.6 and
    the error names the standard uses for orders)."""

    VALIDATION = "validationError"
    ORDER = "orderError"
    ORDER_UPDATE = "orderUpdateError"
    NO_ROUTE = "noRouteError"
    NO_ORDER_TO_CANCEL = "noOrderToCancel"
    ACTION = "actionError"
    OPERATOR = "operatorHasControls"
    MISSION = "missionFailed"
    BROKER = "brokerLost"
    BOARD = "boardLinkLost"
    FLOOD = "messageFlood"


@dataclass(frozen=True)
class Refusal(Exception):
    """Why an order, or an instant action, cannot be done: a VDA 5050 error."""

    kind: ErrorType
    description: str
    node_id: str | None = None

    def __str__(self) -> str:
        return f"{self.kind.value}: {self.description}"


class NodeKind(enum.Enum):
    ROOM = "room"
    DOOR = "door"


@dataclass(frozen=True)
class Node:
    node_id: str
    sequence_id: int
    released: bool
    kind: NodeKind


@dataclass(frozen=True)
class Edge:
    edge_id: str
    sequence_id: int
    released: bool
    start: str
    end: str


@dataclass(frozen=True)
class Order:
    """An order read against the plan: its nodes and edges in sequence."""

    order_id: str
    update_id: int
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]

    @property
    def first(self) -> Node:
        return self.nodes[0]

    @property
    def base(self) -> tuple[Node, ...]:
        """The released nodes (the base); the rest is the horizon."""
        return tuple(node for node in self.nodes if node.released)

    @property
    def horizon(self) -> bool:
        return len(self.base) < len(self.nodes)

    def rooms(self, nodes: tuple[Node, ...]) -> list[str]:
        return [node.node_id for node in nodes if node.kind is NodeKind.ROOM]


def read_order(message: dict[str, Any], plan: FloorPlan, max_speed: float) -> Order:
    """The order in `message` (already checked against the standard's schema) read
    against `plan`; Refusal if its shape or a node is wrong, or an edge asks for less
    than `max_speed` (the robot's `go` cannot be held lower along one edge: refused,
    not ignored, since a fleet that slows an edge means it for safety)."""
    order_id, update_id = str(message["orderId"]), int(message["orderUpdateId"])
    raw_nodes, raw_edges = message["nodes"], message["edges"]
    if not raw_nodes:
        raise Refusal(ErrorType.VALIDATION, "an order without nodes")
    if len(raw_nodes) > MAX_NODES:
        raise Refusal(ErrorType.VALIDATION, f"{len(raw_nodes)} nodes; at most {MAX_NODES}")
    if len(raw_edges) != len(raw_nodes) - 1:
        raise Refusal(
            ErrorType.VALIDATION,
            f"{len(raw_nodes)} nodes want {len(raw_nodes) - 1} edges, not {len(raw_edges)}",
        )
    nodes = sorted(raw_nodes, key=lambda node: node["sequenceId"])
    edges = sorted(raw_edges, key=lambda edge: edge["sequenceId"])
    read_nodes = tuple(_node(raw, plan) for raw in nodes)
    read_edges = tuple(_edge(raw, max_speed) for raw in edges)
    for index, edge in enumerate(read_edges):
        before, after = read_nodes[index], read_nodes[index + 1]
        if not before.sequence_id < edge.sequence_id < after.sequence_id:
            raise Refusal(
                ErrorType.VALIDATION,
                f"edge {edge.edge_id} is not between nodes "
                f"{before.node_id} and {after.node_id} by "
                "sequenceId",
            )
        if (edge.start, edge.end) != (before.node_id, after.node_id):
            raise Refusal(
                ErrorType.VALIDATION,
                f"edge {edge.edge_id} joins {edge.start} to "
                f"{edge.end}, not {before.node_id} to "
                f"{after.node_id}",
            )
        if edge.released != after.released:
            raise Refusal(
                ErrorType.VALIDATION,
                f"edge {edge.edge_id} is {'' if edge.released else 'not '}released but node "
                f"{after.node_id} after it is {'not ' if edge.released else ''}released",
            )
    released = [node.released for node in read_nodes]
    if not released[0]:
        raise Refusal(ErrorType.VALIDATION, "the first node is not released")
    if any(later and not earlier for earlier, later in itertools.pairwise(released)):
        raise Refusal(ErrorType.VALIDATION, "a released node after the horizon")
    for index, node in enumerate(read_nodes):
        if node.kind is NodeKind.DOOR:
            _door_between(plan, read_nodes, index)
    if read_nodes[-1].kind is NodeKind.DOOR and read_nodes[-1].released:
        # A robot does not stop in a doorway: in the way of every other passer-by.
        raise Refusal(
            ErrorType.VALIDATION,
            f"the order ends in door {read_nodes[-1].node_id}; it must end in a room",
            read_nodes[-1].node_id,
        )
    return Order(order_id, update_id, read_nodes, read_edges)


def _node(raw: dict[str, Any], plan: FloorPlan) -> Node:
    node_id = str(raw["nodeId"])
    if raw.get("actions"):
        types = ", ".join(sorted({str(action.get("actionType")) for action in raw["actions"]}))
        raise Refusal(
            ErrorType.ORDER,
            f"node {node_id} asks for {types}: this vehicle takes no node actions (its factsheet)",
            node_id,
        )
    doors = {door.id: door for door in plan.doors}
    if node_id in plan.rooms:
        kind, point = NodeKind.ROOM, plan.rooms[node_id].at
    elif node_id in doors:
        kind, point = NodeKind.DOOR, doors[node_id].at
    else:
        raise Refusal(
            ErrorType.ORDER,
            f"node {node_id} is not a room or a door of the robot's plan {plan.name}",
            node_id,
        )
    position = raw.get("nodePosition")
    if position is not None:
        if position.get("mapId") != plan.name:
            raise Refusal(
                ErrorType.ORDER,
                f"node {node_id} is on map {position.get('mapId')}; the robot's is {plan.name}",
                node_id,
            )
        try:
            off = math.dist((float(position["x"]), float(position["y"])), point)
        except OverflowError:  # an integer beyond any float: nowhere on the map
            off = math.inf
        if not off <= NODE_TOLERANCE_M:
            raise Refusal(
                ErrorType.ORDER,
                f"node {node_id} is {off:.2f} m from where the plan "
                f"has it (at most {NODE_TOLERANCE_M} m)",
                node_id,
            )
    return Node(node_id, int(raw["sequenceId"]), bool(raw["released"]), kind)


def _edge(raw: dict[str, Any], max_speed: float) -> Edge:
    edge_id = str(raw["edgeId"])
    slower = raw.get("maxSpeed")
    if slower is not None and not float(slower) >= max_speed:
        raise Refusal(
            ErrorType.ORDER,
            f"edge {edge_id} asks for at most {float(slower):g} m/s; "
            f"this vehicle's way is driven at up to {max_speed:g} "
            "m/s and cannot be held lower along one edge",
        )
    if raw.get("actions"):
        raise Refusal(
            ErrorType.ORDER,
            f"edge {edge_id} asks for actions: this vehicle takes no edge actions (its factsheet)",
        )
    return Edge(
        edge_id,
        int(raw["sequenceId"]),
        bool(raw["released"]),
        str(raw["startNodeId"]),
        str(raw["endNodeId"]),
    )


def _door_between(plan: FloorPlan, nodes: tuple[Node, ...], index: int) -> None:
    """A door node must join the rooms on either side of it in the order."""
    door = next(door for door in plan.doors if door.id == nodes[index].node_id)
    before = nodes[index - 1].node_id if index > 0 else None
    after = nodes[index + 1].node_id if index + 1 < len(nodes) else None
    if before is None:
        raise Refusal(
            ErrorType.ORDER,
            f"the order starts in door {door.id}; a robot stands in a room",
            door.id,
        )
    if after is not None and {before, after} != set(door.between):
        raise Refusal(
            ErrorType.ORDER,
            f"door {door.id} joins {door.between[0]} and "
            f"{door.between[1]}, not {before} and {after}",
            door.id,
        )
    if after is None and before not in door.between:
        raise Refusal(ErrorType.ORDER, f"door {door.id} is not a door of {before}", door.id)
