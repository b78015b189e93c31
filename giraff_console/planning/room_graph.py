"""The floor plan as a graph of rooms and doorways, searched for routes (thesis §2.6.2).

The thesis stores the floor plan "in graph form, with each node in the graph being the
name and coordinates of a room, and each edge being doorways", and asks A* "which doors
it has to go through". Here each edge is a leg across one room: from the room's point or
a door of it to another door of it (or to the point). A route is a chain of legs, each
ending at a door that is then passed into the next room.

The graph is directed, and its nodes are passings: "through door D into room R" (one for
each side of a door), with each room's point as a start and as an end. A leg joins the
passing into a room to a passing out of it, so a route can never touch a door and turn
back into the room it came from. Legs are shortest ways within a room, so such a touch
is never shorter than the leg that goes straight on; but when the legs are measured
lazily (below), every door on the line between two others looks as short as the leg
between them, and the search used to measure the legs through every door along a
corridor (30 of the 34 legs of the example's first route) before settling on the direct
one. `legs.py` plans each leg of a room in the same window, so that what one leg finds
through a door, the leg that goes straight on finds too.

Each leg's length is the straight line, or, given a `leg_length` (the grid planner's way
round walls and furniture, §2.6.4), that way's length. Measuring a leg on the grid takes
milliseconds and a care home has hundreds of legs, so they are measured lazily (LazySP:
Dellin and Srinivasa, ICAPS 2016): the search runs with straight-line lengths for the
legs not yet measured, the legs of the route it finds are measured, and it runs again
until every leg of its route is measured. A straight line is never longer than a way
round, so the route is the optimum of the measured lengths.

Speed, at any size: routes are searched by scipy's compiled Dijkstra (csgraph) on a
sparse matrix of the legs, one tree per room that a route starts from, grown when a
route from that room is first asked for and kept until a door opens or closes or a
leg's length changes; each route found is kept too. A door event only marks the door
and drops what was kept: microseconds at 320 rooms, where the former planner built
every route between every pair of rooms again (6.9 s). The first route after it takes
well under a millisecond, and one asked again is looked up in a few microseconds (the
TUI asks as the operator types). tests/planning/test_room_graph.py checks the routes
against networkx's A* on the same legs, and against the former planner's answers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import TYPE_CHECKING, Any

import numpy as np

from giraff_console.planning.floorplan import FloorPlan, Point

if TYPE_CHECKING:
    import networkx as nx
    from scipy.sparse import csr_array  # type: ignore[import-untyped]

Node = tuple[str, str]  # ("room", id) or ("door", id): the ends of a leg
# The length of the way between two points of a room (its id), or None if there is none.
LegLength = Callable[[Point, Point, str], float | None]


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

    def copy(self) -> Route:
        """A copy whose lists the caller may change without changing what is kept."""
        return Route(list(self.rooms), list(self.doors), self.length_m, list(self.path),
                     list(self.leg_rooms))  # fmt: skip


def euclidean(a: Point, b: Point) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


@dataclass(frozen=True)
class _Leg:
    ends: frozenset[Node]
    room: str
    a: Point
    b: Point


class RoomGraph:
    """Rooms and doors of a floor plan as a sparse graph of legs, with doors that can be
    closed and opened while the robot runs.

    Not thread-safe: one owner (the console's planner) asks for routes and closes doors.
    """

    def __init__(self, plan: FloorPlan, leg_length: LegLength | None = None) -> None:
        self.plan = plan
        self.leg_length = leg_length
        self.doors = {door.id: door for door in plan.doors}
        self.closed = {door.id for door in plan.doors if not door.open}
        rooms, doors = list(plan.rooms), plan.doors
        n_rooms = len(rooms)
        # Node numbers: room r's point as a start is r, as an end n_rooms + r; passing
        # door k into door.between[s] is 2 n_rooms + 2 k + s; the robot's point, for
        # route_from, is the last.
        self._start = {room: i for i, room in enumerate(rooms)}
        self._end = {room: n_rooms + i for i, room in enumerate(rooms)}
        self._robot = 2 * n_rooms + 2 * len(doors)
        self._nodes = self._robot + 1
        self._into: list[str] = []  # the room each passing leads into
        self._door_of: list[str] = []  # the door each passing goes through
        for door in doors:
            self._into += list(door.between)
            self._door_of += [door.id, door.id]
        self._legs: list[_Leg] = []
        self._leg_of: dict[tuple[frozenset[Node], str], int] = {}
        src: list[int] = []
        dst: list[int] = []
        leg_ids: list[int] = []

        def join(u: int, v: int, a: Node, b: Node, room: str) -> None:
            key = (frozenset((a, b)), room)
            if key not in self._leg_of:
                self._leg_of[key] = len(self._legs)
                self._legs.append(_Leg(key[0], room, self._point(a), self._point(b)))
            src.append(u)
            dst.append(v)
            leg_ids.append(self._leg_of[key])

        for room in rooms:
            # (door k, passing into the room, passing out of it) for each door of it.
            sides = [(k, 2 * n_rooms + 2 * k + door.between.index(room),
                      2 * n_rooms + 2 * k + 1 - door.between.index(room))
                     for k, door in enumerate(doors) if room in door.between]  # fmt: skip
            here: Node = ("room", room)
            for k, into, out in sides:
                door_node: Node = ("door", doors[k].id)
                join(self._start[room], out, here, door_node, room)
                join(into, self._end[room], door_node, here, room)
                for other, _, other_out in sides:
                    if other != k:
                        join(into, other_out, door_node, ("door", doors[other].id), room)
        self._src = np.array(src, dtype=np.int32)
        self._dst = np.array(dst, dtype=np.int32)
        self._edge_leg = np.array(leg_ids, dtype=np.intp)
        self._edge_of = {(u, v): e for e, (u, v) in enumerate(zip(src, dst, strict=True))}
        self._straight = np.array([euclidean(leg.a, leg.b) for leg in self._legs])
        # Each leg's measured length; NaN while not measured, inf when there is no way.
        self._length = self._straight.copy() if leg_length is None else self._straight * np.nan
        self._door_index = {door.id: k for k, door in enumerate(doors)}
        self._matrix: csr_array | None = None
        self._trees: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._routes: dict[tuple[str, str], Route] = {}

    def close(self, door_id: str) -> None:
        self._door(door_id)
        self.closed.add(door_id)
        self._changed()

    def open(self, door_id: str) -> None:
        self._door(door_id)
        self.closed.discard(door_id)
        self._changed()

    def is_open(self, door_id: str) -> bool:
        self._door(door_id)
        return door_id not in self.closed

    def forget_legs(self) -> None:
        """The grid has changed (an obstacle found or gone): measure legs again as
        routes need them."""
        if self.leg_length is not None:
            self._length[:] = np.nan
        self._changed()

    def measure_all(self) -> None:
        """Measure every leg through open doors now."""
        usable = self._usable_edges()
        for leg in np.unique(self._edge_leg[usable]).tolist():
            if math.isnan(self._length[leg]):
                self._measure(leg)
        self._changed()

    def route(self, from_room: str, to_room: str) -> Route:
        """The shortest route between two rooms' points, through open doors."""
        self._room(from_room)
        self._room(to_room)
        if from_room == to_room:
            return Route([from_room], [], 0.0, [self.plan.rooms[from_room].at], [])
        key = (from_room, to_room)
        if key not in self._routes:
            self._routes[key] = self._search(self._start[from_room], self._end[to_room], None)
        return self._routes[key].copy()

    def route_from(self, point: Point, room_id: str, to_room: str) -> Route:
        """The shortest route from `point`, in room `room_id`, to `to_room`'s point: from
        where the robot stands, not from its room's point."""
        self._room(room_id)
        self._room(to_room)
        robot = _Robot(self, point, room_id)
        return self._search(self._robot, self._end[to_room], robot)

    def xy(self, node: Node) -> Point:
        return self._point(node)

    @property
    def graph(self) -> nx.Graph:
        """The legs through open doors as an undirected networkx graph, nodes ("room",
        id) and ("door", id) with their `xy`, edges with their `weight` (measured, else
        straight), `measured` and `room`; legs with no way across are left out. A view
        for looking at, built on each call; routes are not searched on it."""
        import networkx as nx  # only for this view (issue 26, item 6)

        graph = nx.Graph()
        for room in self.plan.rooms.values():
            graph.add_node(("room", room.id), xy=room.at)
        for door in self.plan.doors:
            if door.id not in self.closed:
                graph.add_node(("door", door.id), xy=door.at)
        for leg_id in np.unique(self._edge_leg[self._usable_edges()]).tolist():
            leg, length = self._legs[leg_id], float(self._length[leg_id])
            a, b = sorted(leg.ends)
            measured = not math.isnan(length)
            graph.add_edge(a, b, weight=length if measured else float(self._straight[leg_id]),
                           measured=measured, room=leg.room)  # fmt: skip
        return graph

    def _point(self, node: Node) -> Point:
        kind, name = node
        return self.plan.rooms[name].at if kind == "room" else self.doors[name].at

    def _room(self, room_id: str) -> None:
        if room_id not in self.plan.rooms:
            raise UnknownRoomError(self.plan.no_room(room_id))

    def _door(self, door_id: str) -> None:
        if door_id not in self.doors:
            known = ", ".join(sorted(self.doors)) or "none"
            raise UnknownDoorError(f"no door called {door_id!r} (doors: {known})")

    def _changed(self) -> None:
        """Doors or lengths have changed: what was searched before no longer holds."""
        self._matrix = None
        self._trees = {}
        self._routes = {}

    def _usable_edges(self) -> np.ndarray:
        """Which edges are legs through open doors with a way across."""
        passable = np.ones(self._nodes, dtype=bool)
        for door_id in self.closed:
            k = 2 * len(self.plan.rooms) + 2 * self._door_index[door_id]
            passable[k : k + 2] = False
        return passable[self._src] & passable[self._dst] & ~np.isinf(self._length[self._edge_leg])

    def _weights(self) -> np.ndarray:
        length = self._length[self._edge_leg]
        return np.where(np.isnan(length), self._straight[self._edge_leg], length)

    def _tree(self, source: int, robot: _Robot | None) -> tuple[np.ndarray, np.ndarray]:
        """Dijkstra's costs and predecessors from `source`, kept until the next change."""
        # Imported at the first route, not with the module: scipy costs the console's
        # start a quarter of a second, and its first screen plans nothing (issue 26,
        # item 6).
        from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

        if robot is None and source in self._trees:
            return self._trees[source]
        if self._matrix is None:
            usable = self._usable_edges()
            self._matrix = self._as_matrix(self._src[usable], self._dst[usable],
                                           self._weights()[usable])  # fmt: skip
        matrix = self._matrix
        if robot is not None:
            usable, weights = self._usable_edges(), robot.weights()
            way = ~np.isinf(weights)
            src = np.concatenate((self._src[usable], robot.src[way]))
            dst = np.concatenate((self._dst[usable], robot.dst[way]))
            matrix = self._as_matrix(src, dst, np.concatenate((self._weights()[usable],
                                                               weights[way])))  # fmt: skip
        costs, before = dijkstra(matrix, directed=True, indices=source, return_predecessors=True)
        if robot is None:
            self._trees[source] = (costs, before)
        return costs, before

    def _as_matrix(self, src: np.ndarray, dst: np.ndarray, weights: np.ndarray) -> csr_array:
        # No two legs join the same pair of nodes, so no entries are summed; csgraph
        # keeps explicit zeros as edges (a door at its room's point is a leg of 0 m).
        from scipy.sparse import csr_array  # type: ignore[import-untyped]  # see _tree

        return csr_array((weights, (src, dst)), shape=(self._nodes, self._nodes))

    def _search(self, source: int, target: int, robot: _Robot | None) -> Route:
        """LazySP: the shortest route on the lengths known, until all of it is measured."""
        while True:
            costs, before = self._tree(source, robot)
            if math.isinf(costs[target]):
                start = robot.room if robot is not None else self._room_of(source)
                raise NoRouteError(f"no route from {start!r} to {self._room_of(target)!r} "
                                   "through open doors")  # fmt: skip
            nodes = [target]
            while nodes[-1] != source:
                nodes.append(int(before[nodes[-1]]))
            nodes.reverse()
            measured_robot = measured = False
            for u, v in pairwise(nodes):
                if u == self._robot:
                    assert robot is not None
                    measured_robot |= robot.measure(v)
                else:
                    leg = int(self._edge_leg[self._edge_of[u, v]])
                    if math.isnan(self._length[leg]):
                        self._measure(leg)
                        measured = True
            if not (measured or measured_robot):
                return self._route(nodes, robot)
            if measured:
                self._changed()

    def _measure(self, leg_id: int) -> None:
        assert self.leg_length is not None
        leg = self._legs[leg_id]
        length = self.leg_length(leg.a, leg.b, leg.room)
        self._length[leg_id] = math.inf if length is None else length

    def _room_of(self, node: int) -> str:
        """The room of a room point's node."""
        rooms = list(self.plan.rooms)
        return rooms[node % len(rooms)]

    def _route(self, nodes: list[int], robot: _Robot | None) -> Route:
        """The rooms, doors, points and length of a chain of nodes."""
        first = robot.room if robot is not None else self._room_of(nodes[0])
        passings = nodes[1:-1]
        start = robot.point if robot is not None else self.plan.rooms[first].at
        rooms = [first] + [self._into[n - 2 * len(self.plan.rooms)] for n in passings]
        doors = [self._door_of[n - 2 * len(self.plan.rooms)] for n in passings]
        path = [start] + [self.doors[door].at for door in doors] + [self.plan.rooms[rooms[-1]].at]
        length = 0.0
        for u, v in pairwise(nodes):
            if u == self._robot:
                assert robot is not None
                length += robot.length(v)
            else:
                length += float(self._length[self._edge_leg[self._edge_of[u, v]]])
        return Route(rooms, doors, length, path, list(rooms))


class _Robot:
    """The legs from where the robot stands, for one route_from: to its room's point
    and to each open door of its room, measured as the search needs them."""

    def __init__(self, graph: RoomGraph, point: Point, room: str) -> None:
        self.graph, self.point, self.room = graph, point, room
        n_rooms = len(graph.plan.rooms)
        ends = {graph._end[room]: graph.plan.rooms[room].at}
        for k, door in enumerate(graph.plan.doors):
            if room in door.between and door.id not in graph.closed:
                ends[2 * n_rooms + 2 * k + 1 - door.between.index(room)] = door.at
        self._ends = ends
        self._lengths: dict[int, float] = (
            {v: euclidean(point, at) for v, at in ends.items()} if graph.leg_length is None else {}
        )
        self.dst = np.array(list(ends), dtype=np.int32)
        self.src = np.full(self.dst.size, graph._robot, dtype=np.int32)

    def weights(self) -> np.ndarray:
        lengths = [self._lengths.get(v, euclidean(self.point, at)) for v, at in self._ends.items()]
        return np.array(lengths, dtype=float).reshape(-1)

    def measure(self, v: int) -> bool:
        """Measure the leg to node v if it is not yet; whether it was measured now."""
        if v in self._lengths:
            return False
        assert self.graph.leg_length is not None
        length = self.graph.leg_length(self.point, self._ends[v], self.room)
        self._lengths[v] = math.inf if length is None else length
        return True

    def length(self, v: int) -> float:
        return self._lengths[v]
