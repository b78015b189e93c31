"""The floor plan as a graph of rooms and doorways, searched for routes (thesis §2.6.2).

The thesis stores the floor plan "in graph form, with each node in the graph being the
name and coordinates of a room, and each edge being doorways", and asks A* "which doors
it has to go through". Here a doorway is a node of its own, joined to the points of its
two rooms and to the other doors of each room, so that a route between two doors can
cross a room without detouring through the room's centre point. Between the doors, the
grid planner (§2.6.4) finds the way round obstacles; its path lengths can replace the
straight-line weights through the `edge_length` hook.

Speed: a route is asked for on every "go <room>", and by the TUI as the operator types,
so a query must take at most 50 µs on a 20-room plan. `nx.astar_path` alone takes about
80 µs a query on the example care home (21 rooms, 20 doors: 41 nodes, 195 edges), so
every route is computed in advance, by Dijkstra from each room, whenever the graph
changes (on construction and on `close` / `open`, about 5 ms there); a query then looks
the route up in about 2 µs. Dijkstra, and A* with the Euclidean heuristic (which
never overestimates, edges being at least straight-line long), find the same optimum;
tests/planning/test_room_graph.py checks the table against `nx.astar_path`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import networkx as nx

from giraff_console.planning.floorplan import FloorPlan, Point

Node = tuple[str, str]  # ("room", id) or ("door", id)
EdgeLength = Callable[[Point, Point], float | None]


class PlanningError(Exception):
    """A route that cannot be planned; the message is for the operator."""


class UnknownRoomError(PlanningError):
    pass


class UnknownDoorError(PlanningError):
    pass


class NoRouteError(PlanningError):
    pass


@dataclass(frozen=True)
class Route:
    rooms: list[str]  # the rooms visited, from the start to the goal
    doors: list[str]  # the ids of the doors passed through, in order
    length_m: float
    path: list[Point]  # the polyline driven: room points and door centres

    def as_json(self) -> dict[str, Any]:
        return {
            "from": self.rooms[0],
            "to": self.rooms[-1],
            "rooms": list(self.rooms),
            "doors": list(self.doors),
            "length_m": round(self.length_m, 3),
            "path": [[x, y] for x, y in self.path],
        }


def euclidean(a: Point, b: Point) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


class RoomGraph:
    """Rooms and doors of a floor plan as a weighted networkx graph, with doors that can
    be closed and opened while the robot runs."""

    def __init__(self, plan: FloorPlan, edge_length: EdgeLength | None = None) -> None:
        self.plan = plan
        self.edge_length = edge_length or euclidean
        self.doors = {door.id: door for door in plan.doors}
        self.closed = {door.id for door in plan.doors if not door.open}
        self.graph = nx.Graph()
        self._routes: dict[str, dict[str, Route]] = {}
        self._rebuild()

    def close(self, door_id: str) -> None:
        self._door(door_id)
        self.closed.add(door_id)
        self._rebuild()

    def open(self, door_id: str) -> None:
        self._door(door_id)
        self.closed.discard(door_id)
        self._rebuild()

    def is_open(self, door_id: str) -> bool:
        self._door(door_id)
        return door_id not in self.closed

    def route(self, from_room: str, to_room: str) -> Route:
        """The shortest route between two rooms' points, through open doors."""
        for room_id in (from_room, to_room):
            if room_id not in self.plan.rooms:
                known = ", ".join(sorted(self.plan.rooms))
                raise UnknownRoomError(f"no room called {room_id!r} (rooms: {known})")
        route = self._routes[from_room].get(to_room)
        if route is None:
            raise NoRouteError(f"no route from {from_room!r} to {to_room!r} through open doors")
        # Copies, so that a caller changing its route cannot change the table.
        return Route(list(route.rooms), list(route.doors), route.length_m, list(route.path))

    def xy(self, node: Node) -> Point:
        return self.graph.nodes[node]["xy"]

    def _door(self, door_id: str) -> None:
        if door_id not in self.doors:
            known = ", ".join(sorted(self.doors)) or "none"
            raise UnknownDoorError(f"no door called {door_id!r} (doors: {known})")

    def _join(self, a: Node, b: Node) -> None:
        length = self.edge_length(self.xy(a), self.xy(b))
        if length is not None:
            self.graph.add_edge(a, b, weight=length)

    def _rebuild(self) -> None:
        graph = self.graph = nx.Graph()
        for room in self.plan.rooms.values():
            graph.add_node(("room", room.id), xy=room.at)
        doors_of: dict[str, list[str]] = {room_id: [] for room_id in self.plan.rooms}
        for door in self.doors.values():
            if door.id in self.closed:
                continue  # a closed door is no way through
            graph.add_node(("door", door.id), xy=door.at)
            for room_id in door.between:
                self._join(("door", door.id), ("room", room_id))
                for other in doors_of[room_id]:
                    self._join(("door", door.id), ("door", other))
                doors_of[room_id].append(door.id)
        self._routes = {}
        for room_id in self.plan.rooms:
            lengths, paths = nx.single_source_dijkstra(graph, ("room", room_id))
            self._routes[room_id] = {
                node[1]: self._route(room_id, path, lengths[node])
                for node, path in paths.items()
                if node[0] == "room"
            }

    def _route(self, from_room: str, nodes: list[Node], length: float) -> Route:
        """Name the rooms and doors along a path of nodes. A door is passed when the
        next leg runs through the room on its far side; a leg from a door to another
        door of the same room touches the first without passing it."""
        rooms, doors, here = [from_room], [], from_room
        for node, after in pairwise(nodes[1:]):
            if node[0] != "door":
                continue
            a, b = self.doors[node[1]].between
            beyond = b if here == a else a
            if after[0] == "room":
                crossed = after[1] == beyond
            else:
                crossed = beyond in self.doors[after[1]].between
            if crossed:
                doors.append(node[1])
                rooms.append(beyond)
                here = beyond
        return Route(rooms, doors, float(length), [self.xy(node) for node in nodes])
