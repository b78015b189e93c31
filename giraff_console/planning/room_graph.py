"""The floor plan as a graph of rooms and doorways, searched for routes (thesis §2.6.2).

The thesis stores the floor plan "in graph form, with each node in the graph being the
name and coordinates of a room, and each edge being doorways", and asks A* "which doors
it has to go through". Here a doorway is a node of its own, joined to the points of its
two rooms and to the other doors of each room, so that a route between two doors can
cross a room without detouring through the room's centre point.

Each edge is a leg across one room. Its length is the straight line, or, given a
`leg_length` (the grid planner's way round walls and furniture, §2.6.4), that way's
length. Measuring a leg on the grid takes milliseconds and a care home has hundreds of
legs, so they are measured lazily (LazySP: Dellin and Srinivasa, ICAPS 2016): A* runs
with straight-line lengths for the legs not yet measured, the legs of the route it finds
are measured, and it runs again until every leg of its route is measured. A straight
line is never longer than a way round, so the route is the optimum of the measured
lengths, found after measuring a few dozen legs rather than all of them.

Speed: a route is asked for on every "go <room>", and by the TUI as the operator types,
so a query must take at most 50 µs on a 20-room plan. `nx.astar_path` alone takes about
100 µs a query on the example care home, so once every leg is measured (at once without
a grid, or after `measure_all`) every route is computed in advance, by Dijkstra from
each room, whenever the graph changes; a query then looks the route up in about 2 µs.
Dijkstra, and A* with the Euclidean heuristic (which never overestimates, legs being at
least straight-line long), find the same optimum; tests/planning/test_room_graph.py
checks the table against `nx.astar_path`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import networkx as nx

from giraff_console.planning.floorplan import FloorPlan, Point

Node = tuple[str, str]  # ("room", id), ("door", id), or ("robot", "") for route_from
# The length of the way between two points of a room (its id), or None if there is none.
LegLength = Callable[[Point, Point, str], float | None]
_ROBOT: Node = ("robot", "")


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
    path: list[Point]  # the room points and door centres passed, from start to goal
    leg_rooms: list[str]  # the room each leg of `path` crosses

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
    be closed and opened while the robot runs.

    Not thread-safe: one owner (the console's planner) asks for routes and closes doors.
    """

    def __init__(self, plan: FloorPlan, leg_length: LegLength | None = None) -> None:
        self.plan = plan
        self.leg_length = leg_length
        self.doors = {door.id: door for door in plan.doors}
        self.closed = {door.id for door in plan.doors if not door.open}
        # Legs measured so far, by their two ends; None for a leg with no way across.
        self._measured: dict[frozenset[Node], float | None] = {}
        self.graph = nx.Graph()
        self._routes: dict[str, dict[str, Route]] | None = None
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

    def forget_legs(self) -> None:
        """The grid has changed (an obstacle found or gone): measure legs again as
        routes need them."""
        self._measured.clear()
        self._rebuild()

    def measure_all(self) -> None:
        """Measure every leg now, so that every route can be looked up in advance."""
        for a, b in list(self.graph.edges):
            if not self.graph.edges[a, b]["measured"]:
                self._measure(a, b)
        self._rebuild()

    def route(self, from_room: str, to_room: str) -> Route:
        """The shortest route between two rooms' points, through open doors."""
        self._room(from_room)
        self._room(to_room)
        if self._routes is not None:
            route = self._routes[from_room].get(to_room)
            if route is None:
                raise NoRouteError(f"no route from {from_room!r} to {to_room!r} through open doors")
            # Copies, so that a caller changing its route cannot change the table.
            return Route(list(route.rooms), list(route.doors), route.length_m, list(route.path),
                         list(route.leg_rooms))  # fmt: skip
        return self._search(("room", from_room), from_room, to_room)

    def route_from(self, point: Point, room_id: str, to_room: str) -> Route:
        """The shortest route from `point`, in room `room_id`, to `to_room`'s point: from
        where the robot stands, not from its room's point."""
        self._room(room_id)
        self._room(to_room)
        graph = self.graph
        graph.add_node(_ROBOT, xy=point)
        try:
            self._join(_ROBOT, ("room", room_id), room_id)
            for door in self.doors.values():
                if room_id in door.between and door.id not in self.closed:
                    self._join(_ROBOT, ("door", door.id), room_id)
            return self._search(_ROBOT, room_id, to_room)
        finally:
            graph.remove_node(_ROBOT)
            for key in [key for key in self._measured if _ROBOT in key]:
                del self._measured[key]

    def xy(self, node: Node) -> Point:
        return self.graph.nodes[node]["xy"]

    def _room(self, room_id: str) -> None:
        if room_id not in self.plan.rooms:
            known = ", ".join(sorted(self.plan.rooms))
            raise UnknownRoomError(f"no room called {room_id!r} (rooms: {known})")

    def _door(self, door_id: str) -> None:
        if door_id not in self.doors:
            known = ", ".join(sorted(self.doors)) or "none"
            raise UnknownDoorError(f"no door called {door_id!r} (doors: {known})")

    def _join(self, a: Node, b: Node, room_id: str) -> None:
        """An edge for the leg between a and b across `room_id`: measured if it has been,
        else as long as the straight line, which no way across can beat."""
        key = frozenset((a, b))
        if key in self._measured:
            length = self._measured[key]
            if length is not None:
                self.graph.add_edge(a, b, weight=length, measured=True, room=room_id)
            return
        straight = euclidean(self.xy(a), self.xy(b))
        measured = self.leg_length is None
        self.graph.add_edge(a, b, weight=straight, measured=measured, room=room_id)

    def _measure(self, a: Node, b: Node) -> None:
        assert self.leg_length is not None
        edge = self.graph.edges[a, b]
        length = self.leg_length(self.xy(a), self.xy(b), edge["room"])
        self._measured[frozenset((a, b))] = length
        if length is None:
            self.graph.remove_edge(a, b)
        else:
            edge.update(weight=length, measured=True)

    def _search(self, start: Node, from_room: str, to_room: str) -> Route:
        """LazySP: A* with the legs measured so far, until its route is all measured."""
        graph, goal = self.graph, ("room", to_room)

        def heuristic(node: Node, _goal: Node) -> float:
            return euclidean(graph.nodes[node]["xy"], graph.nodes[goal]["xy"])

        while True:
            try:
                nodes = nx.astar_path(graph, start, goal, heuristic, "weight")
            except nx.NetworkXNoPath:
                raise NoRouteError(
                    f"no route from {from_room!r} to {to_room!r} through open doors"
                ) from None
            legs = [(a, b) for a, b in pairwise(nodes) if not graph.edges[a, b]["measured"]]
            if not legs:
                length = sum(graph.edges[a, b]["weight"] for a, b in pairwise(nodes))
                return self._route(from_room, nodes, length)
            for a, b in legs:
                self._measure(a, b)

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
                self._join(("door", door.id), ("room", room_id), room_id)
                for other in doors_of[room_id]:
                    self._join(("door", door.id), ("door", other), room_id)
                doors_of[room_id].append(door.id)
        self._routes = None
        if all(measured for _, _, measured in graph.edges.data("measured")):
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
        leg_rooms = [self.graph.edges[a, b]["room"] for a, b in pairwise(nodes)]
        return Route(rooms, doors, float(length), [self.xy(node) for node in nodes], leg_rooms)
