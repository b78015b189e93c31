"""What the range finder sees of the way ahead, for a path mission (§2.6.4, issue 12).

Each sweep puts what the beams meet into the grid and takes out what they now see
through (navigation.py's report_obstacles), and the D* Lite planner of the leg the
robot is on replans incrementally from the cells that changed. Then the path ahead is
checked against the grid as it now is: within LOOKOUT_M of the drive under way, or of
the next one after a turn on the spot. A path mission (path_mission.py) stops and
plans again when it is blocked.

A sensor that sees the building's walls too (a 360° lidar, lidar/; its scans say so,
`sees_walls`) would paint them into the grid again, a few centimetres off where the pose
is a few centimetres off, and narrow every doorway it looks through. So its hit within
KNOWN_WALL_M of what the plan's grid already has blocked is that wall, not an obstacle:
its beam counts as seen through up to it, and nothing is blocked. A sensor that sees
only what is in the way (the simulator's range finder) has every hit counted: the
price of the filter, an obstacle against a wall missed, is paid only where it buys
something.

Its walls, the doorways' jambs among them, show where each doorway really is
(door_sighting.py): the navigator keeps that for the crossings it plans, and a doorway
ahead that a plan made now would cross elsewhere (`doorway_off`) is a reason to stop
and plan again too, once for each door.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from itertools import pairwise
from typing import Protocol

import numpy as np

from giraff_console.missions.door_sighting import Revolution
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.pose_trail import REVOLUTION_S, PoseTrail
from giraff_console.motion.executor import Executor
from giraff_console.motion.path import Drive
from giraff_console.planning.grid import FREE, OccupancyGrid
from giraff_console.planning.legs import Leg
from giraff_console.planning.route_planner import PlannedPath
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]


class Scan(Protocol):
    """One sweep of a range finder, as a LIDAR's scan message has it: each beam's
    (distance, bearing) in the robot's frame, bearing positive left; a distance beyond
    `range_max` (ROS REP 117's +inf) says the beam met nothing within range."""

    @property
    def range_max(self) -> float: ...

    @property
    def beams(self) -> Sequence[tuple[float, float]]: ...

    @property
    def sees_walls(self) -> bool:
        """Whether the sensor sees the building's walls as well as what is in the way."""

    @property
    def taken_at(self) -> float | None:
        """When the sweep ended, on the loop's clock; None for one read on the tick."""

    @property
    def whole(self) -> bool:
        """Whether it swept the turn once with no sample lost (lidar/scan.py): a piece
        of one still shows what is in the way, but not where a doorway is."""


Sense = Callable[[], Scan]

# How far along the path ahead sensed obstacles are looked for.
LOOKOUT_M = 3.0
# Leaving the margin round a sensed obstacle, the path may come this much closer to it:
# the samples of a path along the obstacle's side wobble by a few millimetres.
MARGIN_TOLERANCE_M = 0.01
# A hit this near a cell the plan's grid blocks is the plan's wall seen again: between
# marker fixes the pose drifts (odometry, §2.3; on the imperfect simulator 0.1 to 0.2 m
# over a few metres, and a degree or two, which at 1.5 m moves a wall 5 cm more). An
# obstacle this close to a wall is missed; one in a 0.8 m doorway's middle is not.
KNOWN_WALL_M = 0.25
# A doorway seen so that a plan made now would cross it more than this off where the plan
# under way does (door_sighting.py) is worth a stop to plan the crossing again...
RESIGHT_M = 0.02
# ...while the robot is still this far from it: not yet on the crossing's straight run in
# (APPROACH_M's longest, 0.9 m), or near its start, where the new plan lines up on the
# crossing before the door (route_planner.py's LINE_UP_M). Coming along a corridor to a
# door in its side, the lidar sees the far jamb only from about here: at a glancing
# angle its beams are too far apart on the wall.
RESIGHT_FROM_M = 1.0
# Within this of a doorway's middle the robot is in it, or its body is.
IN_DOORWAY_M = 0.6


class Lookout:
    """The range finder's sweeps for one path mission: into the grid, and the path
    ahead checked against it."""

    def __init__(self, navigator: Navigator, sense: Sense) -> None:
        self.navigator = navigator
        self.sense = sense
        self._planned: PlannedPath | None = None
        self._leg: Leg | None = None
        self._leg_index = -1
        self._walls: KnownWalls | None = None  # made when a sensor that sees walls first says
        self._trail = PoseTrail()  # where the robot was, for a revolution taken before now
        self._doorways_moved: set[str] = set()  # seen to move, not yet weighed (`doorway_off`)
        self._resighted: set[str] = set()  # doors this mission stopped to cross anew, once each

    def new_plan(self, planned: PlannedPath | None) -> None:
        """The mission drives a new plan (its route, for the legs' D* Lite planners)."""
        self._planned = planned
        self._leg, self._leg_index = None, -1

    def sweep(self, pose: Pose, now: float) -> None:
        """Put what the range finder sees into the grid, and take out what its beams now
        see through; the leg under way replans from the cells changed. `pose` is the
        robot's at `now`, the tick's time.

        A lidar's revolution was taken up to a turn and a tick before it is read, and
        seen from the pose now, a wall 1.5 m off would move 0.25 m for each 10 degrees
        the robot has turned since: out of KNOWN_WALL_M, into the way (a robot turning
        on its dock to set off saw a wall of phantoms round it, and stopped and planned
        again for ever). So it is seen from where the robot was half way through it;
        turning on the spot at 45 degrees a second, its ends are then 4 degrees off, a
        wall 1.5 m away 0.1 m."""
        self._trail.add(now, pose)
        scan = self.sense()
        if scan.taken_at is not None:
            then = self._trail.at(scan.taken_at - REVOLUTION_S / 2)
            if then is None:
                return  # from before this mission's first tick
            pose = then
        hits: list[Point] = []
        free: list[Point] = []
        walls = self._known_walls() if scan.sees_walls else None
        met: list[Point] = []  # every hit, the walls' too
        for distance, bearing in scan.beams:
            if math.isnan(distance):
                continue  # a failed measurement (REP 117) says nothing either way
            seen = distance <= scan.range_max
            reach = distance if seen else scan.range_max
            angle = pose.heading + bearing
            end = (pose.x + reach * math.cos(angle), pose.y + reach * math.sin(angle))
            known = seen and walls is not None and walls.near(end)
            (hits if seen and not known else free).append(end)
            if seen:
                met.append(end)
        if scan.sees_walls and scan.whole and met and scan.taken_at is not None:
            self._see_doorways(pose, scan.taken_at, met)
        changes = self.navigator.report_obstacles(hits, (pose.x, pose.y), free)
        if changes:
            leg = self._current_leg(pose)
            if leg is not None:
                leg.update(changes)

    def _see_doorways(self, pose: Pose, taken_at: float, hits: list[Point]) -> None:
        """The doorways a revolution taken from `pose` shows (door_sighting.py), and how
        the robot moved and turned while it was taken, which can smear them."""
        start = self._trail.at(taken_at - REVOLUTION_S)
        end = self._trail.at(taken_at)
        moved = (end.x - start.x, end.y - start.y) if start and end else (0.0, 0.0)
        revolution = Revolution(np.asarray(hits), (pose.x, pose.y), taken_at, moved,
                                self._trail.turning(taken_at))  # fmt: skip
        self._doorways_moved.update(self.navigator.see_doorways(revolution))

    def doorway_off(self, pose: Pose, doors: Sequence[str],
                    crossings: frozenset[Point]) -> tuple[str, float] | None:  # fmt: skip
        """A door of the plan under way (`doors`, crossed at `crossings`) whose doorway
        has been seen since so that a plan made now would cross it more than RESIGHT_M
        from where this one does, and how far: while the door is still ahead and
        RESIGHT_FROM_M or more away, and the robot stands in no doorway, where a stop to
        plan again would leave it turning in the door frame. Once for each door in a
        mission; None if there is none."""
        pending = self._doorways_moved & set(doors)
        if not pending:
            return None
        plan = self.navigator.plan
        here = (pose.x, pose.y)
        if any(math.dist(here, door.at) < IN_DOORWAY_M for door in plan.doors):
            return None  # weighed once out of it
        self._doorways_moved = set()
        heading = (math.cos(pose.heading), math.sin(pose.heading))
        for door in plan.doors:
            if door.id not in pending or door.id in self._resighted or not crossings:
                continue
            dx, dy = door.at[0] - pose.x, door.at[1] - pose.y
            if dx * heading[0] + dy * heading[1] <= 0 or math.hypot(dx, dy) < RESIGHT_FROM_M:
                continue  # passed, or too near to stop short of its crossing
            planned = min(crossings, key=lambda point: math.dist(point, door.at))
            middle = self.navigator.crossing_middle(door.id)
            if middle is None or math.dist(planned, door.at) > door.width / 2:
                continue
            off = math.dist(planned, middle)
            if off > RESIGHT_M:
                self._resighted.add(door.id)
                return door.id, off
        return None

    def _known_walls(self) -> KnownWalls | None:
        if self._walls is None and self.navigator.walls is not None:
            self._walls = KnownWalls(self.navigator.walls)
        return self._walls

    def blocks(self, executor: Executor) -> bool:
        """Whether the grid, as it now is, blocks the path within LOOKOUT_M ahead: of
        the drive under way, or of the next one after a turn on the spot."""
        legs = self.navigator.planner.legs
        if legs is None or executor.finished or not self.navigator.state.obstacles:
            return False
        drives = [s for s in executor.sections[executor.index :] if isinstance(s, Drive)]
        if not drives:
            return False
        section = drives[0]
        start = executor.progress if section is executor.sections[executor.index] else 0.0
        end = min(section.length, start + LOOKOUT_M)
        samples = max(2, math.ceil((end - start) / 0.05) + 1)
        points = []
        for i in range(samples):
            p = section.pose_at(start + (end - start) * i / (samples - 1))
            points.append((p.x, p.y))
        return not all(legs.clear(a, b) for a, b in pairwise(self._past_margin(points)))

    def _past_margin(self, points: list[Point]) -> list[Point]:
        """The path ahead from where it leaves the margin round what was sensed, when
        the robot stands in that margin and the path takes it no closer.

        A box put down beside the robot blocks the grid's cells under the robot itself
        (they are grown by its radius and the clearance), so every new plan would look
        blocked at once and be given up: the robot stopped and replanned for ever. A
        path that heads away from the box, or past it no closer, is the way out; one
        that heads closer is still blocked."""
        legs = self.navigator.planner.legs
        sensed = self.navigator.state.obstacles
        if legs is None or not sensed:
            return points

        seen = np.asarray(sensed)

        def nearest(point: Point) -> float:
            return float(np.hypot(seen[:, 0] - point[0], seen[:, 1] - point[1]).min())

        # Measured from where the path starts, not sample to sample: a path may not
        # creep in a little at a time.
        floor = nearest(points[0]) - MARGIN_TOLERANCE_M
        for i, point in enumerate(points):
            if legs.clear(point, point) or nearest(point) < floor:
                return points[i:]  # out of the margin, or closer in: the grid decides
        return points[-1:]

    def _current_leg(self, pose: Pose) -> Leg | None:
        """The D* Lite planner of the leg the robot is on, kept from one sighting to the
        next so that each replans incrementally."""
        legs = self.navigator.planner.legs
        if legs is None or self._planned is None:
            return None
        route = self._planned.route
        if len(route.path) < 2:
            return None
        here = (pose.x, pose.y)
        index = min(
            range(len(route.path) - 1),
            key=lambda i: _distance_to_segment(here, route.path[i], route.path[i + 1]),
        )
        if self._leg is None or index != self._leg_index:
            self._leg = legs.leg(here, route.path[index + 1], route.leg_rooms[index])
            self._leg_index = index
        self._leg.move_to(here)
        return self._leg


def _distance_to_segment(p: Point, a: Point, b: Point) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    span = dx * dx + dy * dy
    t = 0.0 if span == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / span))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


class KnownWalls:
    """How far each point of the map is from what the plan's grid blocks (walls, and
    space the plan does not know), to tell the walls a sensor sees from obstacles."""

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        # Imported here, not with the module: every command that reads the settings
        # imports this module, and scipy.ndimage costs each one's start a seventh of a
        # second, more on a loaded PC (as room_graph.py's scipy, issue 26, item 6).
        from scipy.ndimage import distance_transform_edt  # type: ignore[import-untyped]

        # Metres from each cell to the nearest blocked one (0 on the blocked ones).
        self._distance = distance_transform_edt(grid.cells == FREE) * grid.resolution

    def near(self, point: Point) -> bool:
        """Whether `point` is within KNOWN_WALL_M of the plan's walls; off the map is."""
        try:
            row, col = self.grid.cell_of(*point)
        except ValueError:
            return True
        return bool(self._distance[row, col] <= KNOWN_WALL_M)
