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

from giraff_console.planning.defaults import ROBOT_RADIUS_M
from giraff_console.planning.floorplan import Door, FloorPlan, Point
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.planning.legs import GridLegs, polyline_length
from giraff_console.planning.rasterise import rasterise
from giraff_console.planning.room_graph import NoRouteError, RoomGraph, Route
from giraff_console.planning.ros_map import read_grid_image
from giraff_console.planning.walls import grid_jambs, wall_edge

# The walls are grown by this much more than the robot's radius, so that a path along
# the edge of the free space keeps the robot off them, not touching.
CLEARANCE_M = 0.05
# A doorway is driven straight through, square to its wall, from this far before it to
# this far after it (shorter where that is blocked): the turns into and out of it then
# happen in the rooms, where they have room, rather than across the door frame. Only a
# door in a wall is: one in open floor (an import's door half-way along a lane) is
# driven through as the grid's ways go, or "square" to a wall that is not there would
# add a sideways hop out and back (issue 16: 6.28 m became 9.87 m).
APPROACH_M = (0.9, 0.7, 0.5)
# A crossing that cannot pass a doorway where it was seen is tried this much nearer the
# plan's middle at a time: a fifth of a 5 cm cell.
SHIFT_STEP_M = 0.01
# A robot standing in a crossing's run in this far or more short of the doorway's middle
# drives to the middle first, and straight on from there: a line from it at 10 cm aside
# turns by 11 degrees, and straight on at the middle by as much, well clear of the frame.
LINE_UP_M = 0.5
# Nearer, or too far aside to go straight on out, it drives to the middle if the line
# there turns it by no more than this: a robot backed off a door frame it clipped stood
# 0.31 m short and 0.11 m aside, 19 degrees. It turns back at the middle, in the
# doorway, where its round body sweeps nothing more; the turn charges the casters in
# proportion to its angle (§3.2.1.5), a third of what turning round does at most, and
# they let go as it leaves the doorway.
LINE_UP_TURN = math.radians(30.0)


@dataclass(frozen=True)
class Arrival:
    """Where a route ends when not at its room's point: at `point`, facing `heading`
    (radians), the last `straight` metres driven straight along that heading. A dock
    is driven onto square on (missions/docking.py); a patrol goes back to where it left
    off to charge."""

    point: Point
    heading: float
    straight: float = 0.0

    @property
    def approach(self) -> Point:
        """Where the straight run in starts."""
        return (self.point[0] - self.straight * math.cos(self.heading),
                self.point[1] - self.straight * math.sin(self.heading))  # fmt: skip


@dataclass(frozen=True)
class PlannedPath:
    """A route between rooms and the way across each room on it."""

    route: Route
    legs: tuple[tuple[Point, ...], ...]  # each leg's polyline, ends included
    goal_heading: float | None  # radians counter-clockwise from +x, if the room asks one
    # The doorways' middles crossed straight, square on: the plan's, or where a range
    # sensor saw them (`RoutePlanner.seen_middle`).
    doorways: frozenset[Point] = frozenset()

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
    points and doors alone) none. OSError (GridImageError) if the image cannot be read,
    or does not fill the size its header says."""
    spec = plan.grid
    if spec is None:
        if not any(room.outline for room in plan.rooms.values()):
            return None
        return rasterise(plan)
    pixels = read_grid_image(spec.image)
    return OccupancyGrid.from_image(pixels, spec.resolution, spec.origin[:2], spec.negate,
                                    spec.occupied_thresh, spec.free_thresh)  # fmt: skip


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
        self.legs = (
            GridLegs(plan, grid.inflated(robot_radius + CLEARANCE_M)) if grid is not None else None
        )
        self.graph = RoomGraph(plan, self.legs.length if self.legs is not None else None)
        self._outlines = {
            room.id: np.array(room.outline, dtype=np.float32).reshape(-1, 1, 2)
            for room in plan.rooms.values()
            if room.outline
        }
        self._doors_at = {door.at: door for door in plan.doors}
        self._walls_at: dict[str, tuple[Point, Point, str | None] | None] = {}
        # Where a range sensor has seen a doorway's middle (missions/door_sighting.py),
        # by door id: the way through is crossed there rather than at the plan's.
        self._seen_middles: dict[str, Point] = {}

    def close(self, door_id: str) -> None:
        self.graph.close(door_id)

    def open(self, door_id: str) -> None:
        self.graph.open(door_id)

    def seen_middle(self, door_id: str, middle: Point) -> None:
        """A range sensor sees `door_id`'s doorway's middle at `middle`: its crossing is
        planned there from now on, as near as the plan's own walls leave clear."""
        self._seen_middles[door_id] = middle

    def crossing_middle(self, door: Door) -> Point | None:
        """Where a straight crossing of `door` passes its doorway now (either way: the
        same line); None when it is not crossed straight (`_approach`)."""
        if self.legs is None:
            return None
        crossing = self._approach(door, *door.between)
        return None if crossing is None else crossing[1]

    def seen_middles(self) -> dict[str, Point]:
        """The doorways' middles as seen, by door id (`seen_middle`)."""
        return dict(self._seen_middles)

    def room_at(self, point: Point) -> str:
        """The room that `point` is in: the outline holding it, else the nearest outline,
        else (a plan without outlines) the room whose point is nearest, among those in
        sight on the grid if any is."""
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
        rooms = list(self.plan.rooms.values())
        if self.walls is not None:
            # The nearest point may be the next room's, through a wall: of the rooms
            # whose point can be seen from here, the nearest.
            rooms = [room for room in rooms if self._in_sight(point, room.at)] or rooms
        return min(rooms, key=lambda room: math.dist(room.at, point)).id

    def _in_sight(self, a: Point, b: Point) -> bool:
        """Whether no wall of the plan's own grid (not inflated: a robot beside a wall
        still sees its room) lies on the straight line from a to b."""
        grid = self.walls
        assert grid is not None
        rows, cols = grid.shape
        steps = max(2, math.ceil(math.dist(a, b) / (grid.resolution / 2)) + 1)
        col = np.floor((np.linspace(a[0], b[0], steps) - grid.origin[0]) / grid.resolution)
        up = np.floor((np.linspace(a[1], b[1], steps) - grid.origin[1]) / grid.resolution)
        row = rows - 1 - up
        if col.min() < 0 or row.min() < 0 or col.max() >= cols or row.max() >= rows:
            return False
        return not (grid.cells[row.astype(int), col.astype(int)] == OCCUPIED).any()

    def between_rooms(self, from_room: str, to_room: str) -> PlannedPath:
        """The route from one room's point to another's."""
        return self._ways(lambda: self.graph.route(from_room, to_room), to_room)

    def from_point(self, start: Point, to_room: str) -> PlannedPath:
        """The route from `start` (where the robot stands) to `to_room`'s point."""
        room = self.room_at(start)
        return self._ways(lambda: self.graph.route_from(start, room, to_room), to_room)

    def to_arrival(self, start: Point, arrival: Arrival) -> PlannedPath:
        """The route from `start` to `arrival`'s point, in whatever room that is, ending
        with its straight run in; NoRouteError if that run is not clear."""
        room, to_room = self.room_at(start), self.room_at(arrival.point)
        find_route = lambda: self.graph.route_from(start, room, to_room)  # noqa: E731
        return self._ways(find_route, to_room, arrival)

    def _ways(self, find_route, to_room: str, arrival: Arrival | None = None) -> PlannedPath:
        """The route's legs on the grid. A leg the grid cannot cross has already been
        taken out of the room graph when it was measured, so the route found is one
        whose legs all exist; the loop is only a guard against a grid that changed."""
        for _ in range(len(self.plan.rooms) + len(self.plan.doors) + 1):
            route: Route = find_route()
            found = self._legs(route, arrival)
            if found is not None:
                heading = self.plan.rooms[to_room].heading
                goal_heading = None if heading is None else math.radians(heading)
                if arrival is not None:
                    goal_heading = arrival.heading
                legs, doorways = found
                return PlannedPath(route, legs, goal_heading, doorways)
            self.graph.forget_legs()
        raise NoRouteError(f"no way to {to_room!r} on the grid")

    def _legs(
        self, route: Route, arrival: Arrival | None = None
    ) -> tuple[tuple[tuple[Point, ...], ...], frozenset[Point]] | None:
        """The route's legs on the grid, and the doorways' middles crossed square on;
        None if a leg has no way across its room. With `arrival`, the last leg ends
        there instead of at the room's point."""
        last_room = route.leg_rooms[-1] if route.leg_rooms else self.room_at(route.path[0])
        ending = self._ending(arrival, last_room)
        if self.legs is None:
            # Without a grid the legs are straight; the arrival replaces the room's point.
            leading = route.path[:-1] if len(route.path) > 1 else route.path
            corners = route.path if arrival is None else [*leading, *ending]
            if len(corners) == 1:
                return ((corners[0],),), frozenset()
            return tuple((a, b) for a, b in pairwise(corners)), frozenset()
        if len(route.path) == 1 and arrival is None:
            return ((route.path[0],),), frozenset()
        # Each door crossed becomes a straight stretch through it, from an approach
        # point in the room before to one in the room after; the grid's ways join them.
        # Each waypoint carries the room of the leg that arrives at it (None: straight).
        waypoints: list[tuple[Point, str | None]] = [(route.path[0], None)]
        doorways = set()
        for i, point in enumerate(route.path[1:-1], start=1):
            before, after = route.leg_rooms[i - 1], route.leg_rooms[i]
            door = self._doors_at.get(point)
            crossing = self._approach(door, before, after) if door and before != after else None
            if crossing is None:
                waypoints.append((point, before))
            elif (
                i == 1
                and door is not None
                and (way_on := self._way_on(route.path[0], door, crossing))
            ):
                _, middle, _ = crossing
                waypoints += [(corner, None) for corner in way_on]
                doorways.add(middle)
            else:
                entry, middle, exit_ = crossing
                waypoints += [(entry, before), (middle, None), (exit_, None)]
                doorways.add(middle)
        if arrival is None:
            waypoints.append((route.path[-1], last_room))
        else:
            # Across the room to the approach, then straight in (or across to the point).
            waypoints += list(zip(ending, (last_room, None), strict=False))
        legs = []
        for (a, _), (b, room) in pairwise(waypoints):
            points = [a, b] if room is None else self.legs.path(a, b, room)
            if points is None:
                return None
            legs.append(tuple(points))
        return tuple(legs), frozenset(doorways)

    def _ending(self, arrival: Arrival | None, room: str) -> list[Point]:
        """The points a route ends with: the approach and the arrival point, or just the
        arrival point when there is no straight run in; NoRouteError when that run is not
        clear."""
        if arrival is None:
            return []
        if arrival.straight <= 0:
            return [arrival.point]
        if self.legs is not None and not self.legs.clear(arrival.approach, arrival.point):
            raise NoRouteError(
                f"the last {arrival.straight:g} m to ({arrival.point[0]:.2f}, "
                f"{arrival.point[1]:.2f}) in {room} are not clear to drive straight in"
            )
        return [arrival.approach, arrival.point]

    def _approach(self, door: Door, before: str, after: str) -> tuple[Point, Point, Point] | None:
        """Where to start, pass the middle of, and end a straight crossing of `door`,
        square to its wall, from room `before` to room `after`; None when it is in no
        wall, or when no crossing is clear.

        Through the plan's middle of the doorway, or, where a range sensor has seen the
        doorway (`seen_middle`), through the middle it saw, or as near it along the wall
        as the plan's walls (grown by the radius and CLEARANCE_M) leave the crossing
        clear: a taught map's doorways are a few centimetres narrower than the real ones
        and off their middles, where a 0.8 m door leaves a 0.6 m robot 10 cm a side."""
        assert self.legs is not None
        normal = self._door_normal(door, before, after)
        if normal is None:
            return None
        # Nearest the middle seen first, at any reach: a chair on the long run in must
        # not put the crossing back where the plan has the doorway.
        for at in self._middles(door):
            for reach in APPROACH_M:
                entry = (at[0] - normal[0] * reach, at[1] - normal[1] * reach)
                exit_ = (at[0] + normal[0] * reach, at[1] + normal[1] * reach)
                if self.legs.clear(entry, exit_):
                    return entry, at, exit_
        return None

    def _middles(self, door: Door) -> list[Point]:
        """Where a crossing of `door` may pass its doorway, best first: the middle seen,
        then steps of SHIFT_STEP_M back along the wall to the plan's middle."""
        seen = self._seen_middles.get(door.id)
        if seen is None:
            return [door.at]
        (x, y), (sx, sy) = door.at, seen
        steps = math.ceil(math.dist(door.at, seen) / SHIFT_STEP_M)
        return [(sx + (x - sx) * i / steps, sy + (y - sy) * i / steps) for i in range(steps)] + [
            door.at
        ]

    def _way_on(self, start: Point, door: Door,
                crossing: tuple[Point, Point, Point]) -> list[Point] | None:  # fmt: skip
        """The straight way on, from `start` standing in `door`'s `crossing` (its entry,
        middle and exit: past the entry and short of the exit), to the exit; None when it
        stands elsewhere or has no clear way on.

        Going back to the entry would drive the robot backwards into the room it was
        leaving and turn it round on the spot, twice, in or just before the doorway,
        where the casters then turn it unseen (up to 45 degrees, §3.2.1.5) into the door
        frame. Instead:
        - No further to the side of the middle's line than the body still fits between
          the posts: straight on to the exit. From beside the middle and close to it a
          leg to the middle would be a hop sideways with a turn in the doorway, and the
          line to the exit is never further from the middle's line than `start` is. By
          the middle when still LINE_UP_M short of it: a robot that stopped to plan a
          doorway seen off the plan (missions/lookout.py) would otherwise cross it half
          way between the old line and the new.
        - Further aside, or with the straight line blocked, short of the doorway: by the
          middle, if the line there turns it by LINE_UP_TURN or less. Where the path
          then bends at the middle it may cut the corner by a few centimetres (shaping's
          curve), within the crossing's clearance."""
        assert self.legs is not None
        _, at, exit_ = crossing
        reach = math.dist(at, exit_)
        if reach == 0:
            return None
        normal = ((exit_[0] - at[0]) / reach, (exit_[1] - at[1]) / reach)
        dx, dy = start[0] - at[0], start[1] - at[1]
        along = dx * normal[0] + dy * normal[1]
        aside = abs(dx * normal[1] - dy * normal[0])
        if not -reach < along < reach:
            return None
        # The robot's radius as the margin: the body, not just its centre, fits between
        # the door posts along the whole stretch.
        if aside <= door.width / 2 - self.robot_radius and self.legs.clear(start, exit_):
            return [at, exit_] if along <= -LINE_UP_M else [exit_]
        if (along < 0 and math.atan2(aside, -along) <= LINE_UP_TURN
                and self.legs.clear(start, at) and self.legs.clear(at, exit_)):  # fmt: skip
            return [at, exit_]
        return None

    def _door_normal(self, door: Door, before: str, after: str) -> Point | None:
        """The unit vector square to the wall `door` is in, from `before` to `after`; None
        when there is no wall at the door to cross."""
        wall = self.wall_at(door)
        if wall is None:
            return None
        (ax, ay), (bx, by), room_id = wall
        length = math.hypot(bx - ax, by - ay)
        normal = ((by - ay) / length, -(bx - ax) / length)
        at = door.at
        if room_id is not None:
            # Outward from `before` (or inward to `after`): away from the room's inside.
            probe = (at[0] - normal[0] * 0.05, at[1] - normal[1] * 0.05)
            inside = cv2.pointPolygonTest(self._outlines[room_id], probe, False) >= 0
            way = 1.0 if room_id == before else -1.0
            sign = way if inside else -way
            return normal[0] * sign, normal[1] * sign
        # A wall on the grid alone: towards the side `after`'s point is on, from the side
        # `before`'s is. Only how far each lies across the wall counts, so a long room
        # whose point is far along the wall still tells its side.
        (px, py), (qx, qy) = self.plan.rooms[before].at, self.plan.rooms[after].at
        across = (qx - px) * normal[0] + (qy - py) * normal[1]
        if across == 0:
            return None
        sign = 1.0 if across > 0 else -1.0
        return normal[0] * sign, normal[1] * sign

    def wall_at(self, door: Door) -> tuple[Point, Point, str | None] | None:
        """Two points along the wall `door` is in, and the room whose outline it is an
        edge of (None for a wall on the grid); None when the door is in no wall: neither
        room's outline passes through it, and the grid has no occupied cells on both
        sides of it. The plan's walls never change, so each door's is found once."""
        if door.id not in self._walls_at:
            edge = wall_edge(self.plan, door)
            wall: tuple[Point, Point, str | None] | None = None
            if edge is not None:
                wall = (edge[1], edge[2], edge[0])
            elif self.walls is not None:
                jambs = grid_jambs(self.walls, door)
                if jambs is not None:
                    wall = (jambs[0], jambs[1], None)
            self._walls_at[door.id] = wall
        return self._walls_at[door.id]
