"""Where the operator sends the robot: `go <room>` on the floor plan (thesis §2.5, §2.6).

"Typically, the destination is selected by the user ... resulting in a set of target
coordinates being given to the route planner" (§2.5). The navigator keeps the floor
plan, plans from the pose the odometry gives to the room asked for, and keeps that plan
up to date as the operator closes and opens doors. The console shows its `state`.

Planning a route measures legs on the grid and can take a few hundred milliseconds, so
the console calls it from a worker thread; the state it publishes is immutable and
replaced whole, so the screen can read it at any time.
"""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, replace

from giraff_console.missions.door_sighting import Doorway, Revolution, Sightings
from giraff_console.planning.floorplan import FloorPlan, Point
from giraff_console.planning.grid import Cell, OccupancyGrid
from giraff_console.planning.landmarks import marker_walls
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import (
    CLEARANCE_M,
    ROBOT_RADIUS_M,
    Arrival,
    PlannedPath,
    RoutePlanner,
)
from giraff_console.planning.walls import WallSegment, doorway, wall_segments
from giraff_console.robot.odometry import Pose


@dataclass(frozen=True)
class NavigationState:
    """What the map shows: the goal, its plan, and which doors are shut."""

    goal: str | None = None
    planned: PlannedPath | None = None
    closed: frozenset[str] = frozenset()
    problem: str | None = None  # why there is a goal but no plan
    obstacles: tuple[tuple[float, float], ...] = ()  # sensed, map frame


class Navigator:
    """The floor plan and the route on it; safe to call from any thread."""

    def __init__(self, plan: FloorPlan, walls: OccupancyGrid | None,
                 robot_radius: float = ROBOT_RADIUS_M) -> None:  # fmt: skip
        self.plan = plan
        self.planner = RoutePlanner(plan, walls, robot_radius)
        self._lock = threading.Lock()
        self.state = NavigationState(closed=frozenset(self.planner.graph.closed))
        # Where the goal is when it is not a room's point (the dock), for replanning.
        self._arrival: Arrival | None = None
        self._sightings = Sightings()
        self._doorways: dict[str, Doorway] | None = None  # the plan's doors in walls, by id

    @property
    def walls(self) -> OccupancyGrid | None:
        """The plan's grid, not inflated: what the map draws."""
        return self.planner.walls

    @property
    def start_pose(self) -> Pose | None:
        """Where the plan says the robot starts: its start room's point and heading."""
        if self.plan.start is None:
            return None
        room = self.plan.rooms[self.plan.start]
        return Pose(room.at[0], room.at[1], math.radians(room.heading or 0.0))

    def sight_walls(self) -> list[WallSegment]:
        """What hides a marker from the camera now: the outlines' walls with the doors
        shut; on a plan without outlines, the walls in its grid (landmarks.py's, which
        markers are placed on) and the doorways of the doors shut."""
        plan, closed = self.plan, self.state.closed
        if any(room.outline for room in plan.rooms.values()) or plan.grid is None:
            return wall_segments(plan, closed)
        shut = {door.id for door in plan.doors if not door.open} | closed
        doors = [WallSegment(*doorway(plan, door, self.walls), "door")
                 for door in plan.doors if door.id in shut]  # fmt: skip
        return [*marker_walls(plan).segments, *doors]

    def room_ids(self) -> list[str]:
        return sorted(self.plan.rooms)

    def door_ids(self) -> list[str]:
        return sorted(door.id for door in self.plan.doors)

    def go(self, room_id: str, pose: Pose, afresh: bool = False) -> PlannedPath:
        """Plan from `pose` to `room_id` and make it the route shown; PlanningError with
        a message for the operator if there is none. `afresh`: a new mission's first
        plan, which what was sensed before it does not stop (see _set_goal)."""
        with self._lock:
            return self._set_goal(room_id, None, pose, afresh)

    def arrive(self, goal: str, arrival: Arrival, pose: Pose, afresh: bool = False) -> PlannedPath:
        """Plan from `pose` to `arrival` (shown as `goal`, such as "dock") and make it the
        route shown; PlanningError with a message for the operator if there is none.
        `afresh` as for `go`."""
        with self._lock:
            return self._set_goal(goal, arrival, pose, afresh)

    def room_at(self, point: Point) -> str:
        """The room `point` is in (planning/route_planner.py says how it is judged)."""
        with self._lock:
            return self.planner.room_at(point)

    def check_rooms(self, rooms: Sequence[str]) -> None:
        """PlanningError, with a message for whoever asked, if the robot could not go
        through `rooms` in turn, room to room through the doors open now."""
        with self._lock:
            for here, there in itertools.pairwise(rooms):
                self.planner.graph.route(here, there)

    def close(self, door_id: str, pose: Pose) -> NavigationState:
        """Shut a door; the route, if any, is planned again from `pose`."""
        with self._lock:
            self.planner.close(door_id)
            return self._replan(pose)

    def open(self, door_id: str, pose: Pose) -> NavigationState:
        """Open a door; the route, if any, is planned again from `pose`."""
        with self._lock:
            self.planner.open(door_id)
            return self._replan(pose)

    def use_plan(self, plan: FloorPlan) -> None:
        """Plan on `plan` from now on: the same building with its rooms renamed
        (planning/room_names.py keeps the door ids). The same grid, doors shut, obstacles
        sensed and the doorways' middles a range sensor saw (door_sighting.py) carry
        over; the route shown does not (the caller has no mission running). The new
        planner is made whole before it replaces the old."""
        with self._lock:
            before = self.planner
            planner = RoutePlanner(plan, before.walls, before.robot_radius)
            # As the operator left them, which may not be as the file says.
            for door in plan.doors:
                shut = door.id in before.graph.closed
                if shut != (door.id in planner.graph.closed):
                    (planner.close if shut else planner.open)(door.id)
            if before.legs is not None and planner.legs is not None and before.legs.sensed:
                radius = before.robot_radius + CLEARANCE_M
                planner.legs.block(list(before.legs.sensed.values()), radius)
            for door_id, middle in before.seen_middles().items():
                planner.seen_middle(door_id, middle)
            self._doorways = None
            self.plan, self.planner = plan, planner
            self._arrival = None
            closed = frozenset(planner.graph.closed)
            self.state = NavigationState(closed=closed, obstacles=self.state.obstacles)

    def use_building(self, plan: FloorPlan, walls: OccupancyGrid | None) -> None:
        """Plan on `plan`, a building drawn anew (a map just made, issue 29), from now
        on: its walls, its doors as its file says; nothing sensed or shut on the old
        one carries over, and no route is shown (the caller has no mission running)."""
        with self._lock:
            planner = RoutePlanner(plan, walls, self.planner.robot_radius)
            self.plan, self.planner = plan, planner
            self._arrival = None
            self._sightings, self._doorways = Sightings(), None
            self.state = NavigationState(closed=frozenset(planner.graph.closed))

    def forget(self) -> None:
        """No goal any more (arrived, or the operator stopped it)."""
        with self._lock:
            self._arrival = None
            self.state = NavigationState(closed=self.state.closed, obstacles=self.state.obstacles)

    def report_obstacles(self, points: list[Point], seen_from: Point | None = None,
                         free: Sequence[Point] = (),
                         margin: float = 0.0) -> list[tuple[Cell, bool]]:  # fmt: skip
        """Obstacles sensed at `points` (map frame): the grid's cells round them are
        blocked, legs are measured again as routes need them. With `seen_from`, where
        the range finder stood: what was sensed before on the beams to `points`, and on
        those to `free` (the ends of beams that met nothing), is gone, and its cells
        are freed first. `margin`: the obstacles are known only where they were met (a
        contact), and may reach this much further. Returns the cells that changed, for
        the D* Lite planner of the leg being driven."""
        legs = self.planner.legs
        if legs is None or not (points or free):
            return []
        radius = self.planner.robot_radius + CLEARANCE_M
        with self._lock:
            before = len(legs.sensed)
            freed = []
            if seen_from is not None:
                ends, hits = [*points, *free], [True] * len(points) + [False] * len(free)
                freed = legs.see_through(seen_from, ends, hits, radius)
            cleared = len(legs.sensed)  # the first only takes away, the second only adds
            blocked = legs.block(points, radius + margin)
            # A cell freed and blocked again in the same sweep has not changed.
            freed_cells, blocked_cells = {cell for cell, _ in freed}, {cell for cell, _ in blocked}
            changes = [change for change in freed if change[0] not in blocked_cells]
            changes += [change for change in blocked if change[0] not in freed_cells]
            if changes:
                self.planner.graph.forget_legs()
            if before != cleared or cleared != len(legs.sensed):
                self.state = replace(self.state, obstacles=tuple(legs.sensed.values()))
            return changes

    def see_doorways(self, revolution: Revolution) -> list[str]:
        """A revolution of a range sensor that sees walls: the doorways it shows are
        crossed at the middle it shows from now on (door_sighting.py). Returns the ids
        of the doors whose middle moved."""
        with self._lock:
            if self._doorways is None:
                self._doorways = {}
                for door in self.plan.doors:
                    wall = self.planner.wall_at(door)
                    if wall is not None:  # a door in open floor has no jambs to see
                        self._doorways[door.id] = Doorway.in_wall(door, wall[0], wall[1])
            width = 2 * self.planner.robot_radius
            moved = self._sightings.see(self._doorways.values(), revolution, width)
            for door_id, middle in moved.items():
                self.planner.seen_middle(door_id, self._doorways[door_id].middle_at(middle))
            return list(moved)

    def crossing_middle(self, door_id: str) -> Point | None:
        """Where a plan made now crosses `door_id`'s doorway from its approach (from a
        start within the crossing, it may cross beside it); None if not straight."""
        with self._lock:
            door = next((door for door in self.plan.doors if door.id == door_id), None)
            return None if door is None else self.planner.crossing_middle(door)

    def forget_obstacles(self, points: list[Point], margin: float = 0.0) -> None:
        """Obstacles reported at `points` (with `margin`) are no longer believed: their
        cells are freed, unless something else sensed keeps them blocked."""
        legs = self.planner.legs
        if legs is None or not points:
            return
        with self._lock:
            if legs.unblock(points, self.planner.robot_radius + CLEARANCE_M + margin):
                self.planner.graph.forget_legs()
            self.state = replace(self.state, obstacles=tuple(legs.sensed.values()))

    def _forget_sensed(self) -> bool:
        legs = self.planner.legs
        if legs is None or not legs.forget_sensed():
            return False
        self.planner.graph.forget_legs()
        self.state = replace(self.state, obstacles=())
        return True

    def _replan(self, pose: Pose) -> NavigationState:
        closed = frozenset(self.planner.graph.closed)
        goal, planned, problem = self.state.goal, None, None
        if goal is not None:
            try:
                planned = self._plan_to(goal, self._arrival, pose)
            except PlanningError as error:
                problem = str(error)
        self.state = NavigationState(goal, planned, closed, problem, self.state.obstacles)
        return self.state

    def _set_goal(self, goal: str, arrival: Arrival | None, pose: Pose,
                  afresh: bool = False) -> PlannedPath:  # fmt: skip
        try:
            planned = self._plan_to(goal, arrival, pose)
        except PlanningError:
            # What was sensed before closes every way: a new mission clears it (Nav2's
            # answer, clearing the costmap) and tries. A robot a few centimetres off
            # its estimate sees a narrow doorway's own frames in it, which would keep
            # the doorway shut for every mission after (issue 25). What is really
            # there the range finder sees again, and the mission then plans round it
            # or ends blocked.
            if not (afresh and self._forget_sensed()):
                raise
            planned = self._plan_to(goal, arrival, pose)
        self._arrival = arrival
        self.state = NavigationState(goal, planned, self.state.closed,
                                     obstacles=self.state.obstacles)  # fmt: skip
        return planned

    def _plan_to(self, goal: str, arrival: Arrival | None, pose: Pose) -> PlannedPath:
        """To the room `goal`'s point, or, with an arrival, there."""
        start = (pose.x, pose.y)
        if arrival is None:
            return self.planner.from_point(start, goal)
        return self.planner.to_arrival(start, arrival)
