"""From where the robot stands to a named room: both levels of the thesis's design.

A* over the room graph picks the doors (§2.6.2); D* Lite on the grid finds the way
across each room between them (§2.6.4), with the grid inflated by the robot's radius so
that the robot can be planned for as a point. A door closing is handled on the room
graph, and the grid then plans within the rooms of the new route; a leg the grid cannot
cross (furniture in the way, a doorway narrower than the robot) is taken out of the
room graph, which then routes round it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

import cv2
import numpy as np

from giraff_console.planning.floorplan import FloorPlan, Point
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.legs import GridLegs, polyline_length
from giraff_console.planning.plan_drawing import plan_grid
from giraff_console.planning.room_graph import NoRouteError, RoomGraph, Route

# The Giraff's base is about 0.6 m across.
ROBOT_RADIUS_M = 0.3


@dataclass(frozen=True)
class PlannedPath:
    """A route between rooms and the way across each room on it."""

    route: Route
    legs: tuple[tuple[Point, ...], ...]  # each leg's polyline, ends included
    goal_heading: float | None  # radians counter-clockwise from +x, if the room asks one

    @property
    def path(self) -> list[Point]:
        """The whole polyline, from the start to the goal room's point."""
        points = list(self.legs[0])
        for leg in self.legs[1:]:
            points += leg[1:]
        return points

    @property
    def length_m(self) -> float:
        return polyline_length(self.path)

    def as_json(self) -> dict:
        """The route as `giraff-console plan --json` prints it."""
        data = self.route.as_json()
        data["length_m"] = round(self.length_m, 3)
        data["path"] = [[round(x, 3), round(y, 3)] for x, y in self.path]
        return data


def walls_of(plan: FloorPlan) -> OccupancyGrid | None:
    """The plan's grid: its own image, else one drawn from its outlines, else (a plan of
    points and doors alone) none. OSError if the image cannot be read."""
    if plan.grid is None and not any(room.outline for room in plan.rooms.values()):
        return None
    return plan_grid(plan)


class RoutePlanner:
    """Plans routes on a floor plan; with a grid, the legs are the grid's ways.

    `grid` is the plan's own occupancy grid (walls, not yet inflated); without one the
    legs are straight lines between the room graph's points. Not thread-safe.
    """

    def __init__(self, plan: FloorPlan, grid: OccupancyGrid | None = None,
                 robot_radius: float = ROBOT_RADIUS_M) -> None:  # fmt: skip
        self.plan = plan
        self.walls = grid
        self.robot_radius = robot_radius
        self.legs = GridLegs(plan, grid.inflated(robot_radius)) if grid is not None else None
        self.graph = RoomGraph(plan, self.legs.length if self.legs is not None else None)
        self._outlines = {
            room.id: np.array(room.outline, dtype=np.float32).reshape(-1, 1, 2)
            for room in plan.rooms.values()
            if room.outline
        }

    def close(self, door_id: str) -> None:
        self.graph.close(door_id)

    def open(self, door_id: str) -> None:
        self.graph.open(door_id)

    def room_at(self, point: Point) -> str:
        """The room that `point` is in: the outline holding it, else the nearest outline,
        else (a plan without outlines) the room whose point is nearest."""
        best, best_distance = None, math.inf
        for room_id, outline in self._outlines.items():
            # Positive inside, negative outside: the signed distance to the outline.
            inside = cv2.pointPolygonTest(outline, (float(point[0]), float(point[1])), True)
            if inside >= 0:
                return room_id
            if -inside < best_distance:
                best, best_distance = room_id, -inside
        if best is not None:
            return best
        return min(self.plan.rooms.values(), key=lambda room: math.dist(room.at, point)).id

    def between_rooms(self, from_room: str, to_room: str) -> PlannedPath:
        """The route from one room's point to another's."""
        return self._ways(lambda: self.graph.route(from_room, to_room), to_room)

    def from_point(self, start: Point, to_room: str) -> PlannedPath:
        """The route from `start` (where the robot stands) to `to_room`'s point."""
        room = self.room_at(start)
        return self._ways(lambda: self.graph.route_from(start, room, to_room), to_room)

    def _ways(self, find_route, to_room: str) -> PlannedPath:
        """The route's legs on the grid. A leg the grid cannot cross has already been
        taken out of the room graph when it was measured, so the route found is one
        whose legs all exist; the loop is only a guard against a grid that changed."""
        for _ in range(len(self.plan.rooms) + len(self.plan.doors) + 1):
            route: Route = find_route()
            legs = self._legs(route)
            if legs is not None:
                heading = self.plan.rooms[to_room].heading
                goal_heading = None if heading is None else math.radians(heading)
                return PlannedPath(route, legs, goal_heading)
            self.graph.forget_legs()
        raise NoRouteError(f"no way to {to_room!r} on the grid")

    def _legs(self, route: Route) -> tuple[tuple[Point, ...], ...] | None:
        if len(route.path) == 1:
            return ((route.path[0],),)
        if self.legs is None:
            return tuple((a, b) for a, b in pairwise(route.path))
        legs = []
        for (a, b), room in zip(pairwise(route.path), route.leg_rooms, strict=True):
            points = self.legs.path(a, b, room)
            if points is None:
                return None
            legs.append(tuple(points))
        return tuple(legs)
