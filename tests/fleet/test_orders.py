"""An order read against the robot's plan (fleet/orders.py): its shape, its nodes, and
its doors, each refused with the standard's error and never half taken."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from giraff_console.fleet.orders import (
    NODE_TOLERANCE_M,
    ErrorType,
    NodeKind,
    Refusal,
    read_order,
)
from giraff_console.planning.floorplan import FloorPlan, load_floorplan

CARE_HOME = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"


@pytest.fixture(scope="module")
def plan() -> FloorPlan:
    return load_floorplan(CARE_HOME)


def order(
    nodes: list[str],
    *,
    released: int | None = None,
    positions: dict | None = None,
    actions: dict | None = None,
) -> dict:
    released = len(nodes) if released is None else released
    positions, actions = positions or {}, actions or {}
    raw_nodes = []
    for i, node in enumerate(nodes):
        raw = {
            "nodeId": node,
            "sequenceId": 2 * i,
            "released": i < released,
            "actions": actions.get(node, []),
        }
        if node in positions:
            raw["nodePosition"] = positions[node]
        raw_nodes.append(raw)
    edges = [
        {
            "edgeId": f"e{i}",
            "sequenceId": 2 * i + 1,
            "released": i + 1 < released,
            "startNodeId": a,
            "endNodeId": b,
            "actions": [],
        }
        for i, (a, b) in enumerate(itertools.pairwise(nodes))
    ]
    return {"orderId": "o1", "orderUpdateId": 0, "nodes": raw_nodes, "edges": edges}


def a_door(plan: FloorPlan):
    return next(door for door in plan.doors if all(room in plan.rooms for room in door.between))


def test_rooms_are_nodes_in_order_and_the_unreleased_are_the_horizon(plan):
    rooms = sorted(plan.rooms)[:3]
    read = read_order(order(rooms, released=2), plan, 0.4)
    assert [node.node_id for node in read.nodes] == rooms
    assert [node.node_id for node in read.base] == rooms[:2]
    assert read.horizon
    assert all(node.kind is NodeKind.ROOM for node in read.nodes)


def test_an_unknown_node_is_refused_with_its_id(plan):
    with pytest.raises(Refusal) as refused:
        read_order(order([plan.start, "the-moon"]), plan, 0.4)
    assert refused.value.kind is ErrorType.ORDER
    assert refused.value.node_id == "the-moon"


def test_a_node_where_the_plan_does_not_have_it_is_refused(plan):
    room = plan.rooms[plan.start]
    near = {"x": room.at[0] + NODE_TOLERANCE_M * 0.8, "y": room.at[1], "mapId": plan.name}
    read_order(order([plan.start], positions={plan.start: near}), plan, 0.4)
    far = {"x": room.at[0] + NODE_TOLERANCE_M * 1.5, "y": room.at[1], "mapId": plan.name}
    with pytest.raises(Refusal, match="from where the plan has it"):
        read_order(order([plan.start], positions={plan.start: far}), plan, 0.4)
    other_map = {**near, "mapId": "another building"}
    with pytest.raises(Refusal, match="on map another building"):
        read_order(order([plan.start], positions={plan.start: other_map}), plan, 0.4)


def test_a_door_between_the_rooms_it_joins_is_a_door_node(plan):
    door = a_door(plan)
    read = read_order(order([door.between[0], door.id, door.between[1]]), plan, 0.4)
    assert read.nodes[1].kind is NodeKind.DOOR
    assert read.rooms(read.base) == list(door.between)


def test_a_door_between_other_rooms_or_at_an_end_is_refused(plan):
    door = a_door(plan)
    other = next(room for room in plan.rooms if room not in door.between)
    with pytest.raises(Refusal, match="joins"):
        read_order(order([door.between[0], door.id, other]), plan, 0.4)
    with pytest.raises(Refusal, match="must end in a room"):
        read_order(order([door.between[0], door.id]), plan, 0.4)
    with pytest.raises(Refusal, match="starts in door"):
        read_order(order([door.id, door.between[1]]), plan, 0.4)


def test_node_actions_are_refused_since_the_factsheet_offers_none(plan):
    pick = [{"actionId": "a1", "actionType": "pick", "blockingType": "HARD"}]
    with pytest.raises(Refusal, match="pick"):
        read_order(
            order([plan.start, sorted(plan.rooms)[0]], actions={plan.start: pick}), plan, 0.4
        )


def test_a_badly_shaped_order_is_a_validation_error(plan):
    rooms = sorted(plan.rooms)[:3]
    crossed = order(rooms)
    crossed["edges"][0]["endNodeId"] = rooms[2]
    with pytest.raises(Refusal) as refused:
        read_order(crossed, plan, 0.4)
    assert refused.value.kind is ErrorType.VALIDATION
    missing_edge = order(rooms)
    missing_edge["edges"].pop()
    with pytest.raises(Refusal, match="edges"):
        read_order(missing_edge, plan, 0.4)
    released_after_horizon = order(rooms, released=1)
    released_after_horizon["nodes"][2]["released"] = True
    released_after_horizon["edges"][1]["released"] = True
    with pytest.raises(Refusal, match="horizon"):
        read_order(released_after_horizon, plan, 0.4)
    with pytest.raises(Refusal, match="without nodes"):
        read_order({"orderId": "o", "orderUpdateId": 0, "nodes": [], "edges": []}, plan, 0.4)


def test_an_edge_released_otherwise_than_the_node_after_it_is_refused(plan):
    rooms = sorted(plan.rooms)[:3]
    unreleased_edge = order(rooms)
    unreleased_edge["edges"][0]["released"] = False
    with pytest.raises(Refusal, match="not released but node"):
        read_order(unreleased_edge, plan, 0.4)


def test_an_edge_slower_than_the_robot_drives_is_refused_not_ignored(plan):
    rooms = sorted(plan.rooms)[:2]
    slow = order(rooms)
    slow["edges"][0]["maxSpeed"] = 0.2
    with pytest.raises(Refusal, match=r"at most 0\.2 m/s"):
        read_order(slow, plan, 0.4)
    slow["edges"][0]["maxSpeed"] = 1.0  # faster than it drives anyway: nothing to hold
    read_order(slow, plan, 0.4)
