"""A mission that drives a planned path: shape, drive and watch (thesis §2.7, §2.4).

The planned polyline is shaped into clothoid turns the board can drive without a jump in
its gear ratio (motion/shaping.py), given a jerk-limited speed profile and streamed to
the board tick by tick, steering back onto the path from the odometry
(motion/executor.py). `go <room>` and a taught route followed closed-loop are both this;
they differ in where the path comes from.

While driving, the range finder (§2.4, §6) reports what is ahead. Obstacles go into the
grid, and the D* Lite planner of the leg the robot is on is told, so that it replans
incrementally. If the path ahead is blocked, the robot comes to a jerk-limited stop and
sets off on a new path from where it stands. A stall (motion commanded, the wheels not
turning: §2.3.2) or no way left ends the mission with the reason; ESTOP, a lost link
and the operator's keys end it in the control loop.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.navigation import Navigator
from giraff_console.motion.executor import Executor, Trace
from giraff_console.motion.path import Drive
from giraff_console.motion.shaping import TurnLimits, shape
from giraff_console.motion.speed_profile import MotionLimits, SlowZone
from giraff_console.planning.legs import Leg
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import PlannedPath
from giraff_console.protocol.codec import Command
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]
# A range finder's readings: (distance, bearing) in the robot's frame, bearing positive left.
Sense = Callable[[], list[tuple[float, float]]]
# How far along the path ahead sensed obstacles are looked for.
LOOKOUT_M = 3.0
# A doorway is passed slowly this far either side of its centre.
DOOR_ZONE_M = 0.4
PROGRESS_BAR = 16


@dataclass(frozen=True)
class Course:
    """Where a path mission drives from a pose: the polyline and what it passes."""

    points: list[Point]
    goal_heading: float | None = None  # radians; None: whatever the path ends with
    doorways: frozenset[Point] = frozenset()  # crossed straight (shaping's pins)
    doors: tuple[str, ...] = ()  # the doors passed, by id
    planned: PlannedPath | None = None  # the room graph's route, for D* Lite replanning


class PathMission:
    """A Mission that drives the course `_course` gives, replanning round obstacles.

    Planning happens when the mission is made (PlanningError if there is no way), so
    the console makes it off its UI thread.
    """

    name: str

    def __init__(
        self,
        navigator: Navigator | None,
        pose: Callable[[], Pose],
        *,
        tick: float,
        limits: MotionLimits | None = None,
        turn_limits: TurnLimits | None = None,
        sense: Sense | None = None,
        notify: Callable[[str], None] = lambda text: None,
    ) -> None:
        """`notify` gets a line for the operator when the mission changes its plan."""
        self.navigator = navigator
        self.notify = notify
        self.limits = limits or MotionLimits()
        self.turn_limits = turn_limits or TurnLimits()
        self.tick = tick
        self._pose = pose
        self._sense = sense if navigator is not None else None
        self.problem: str | None = None
        self.replans = 0
        self._started: float | None = None
        self._ended: float | None = None
        self._now = 0.0
        self._paused = False
        self._restart = False  # set off again on a new plan once the robot is still
        # The traces of the plans driven before the present one (after replanning).
        self._traces: list[Trace] = []
        self._leg: Leg | None = None
        self._leg_index = -1
        self.executor = self._plan(pose())
        self.time_optimal = self.executor.time_optimal

    def _course(self, pose: Pose) -> Course:
        """The way to go from `pose`; PlanningError if there is none."""
        raise NotImplementedError

    # -- the Mission protocol -----------------------------------------------------------

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        self._now = now
        if self._started is None:
            self._started = now
        if self._paused or state is None or self.finished or self.problem is not None:
            return []
        pose = self._pose()
        if self._sense is not None:
            self._watch(now, pose)
        closed = self.navigator.state.closed if self.navigator is not None else frozenset()
        if closed != self._closed:
            self._closed = closed
            if closed & set(self._doors) and not self._restart:
                # The operator shut a door on the route: round it, from a stop.
                self.notify(f"{self.name}: {', '.join(sorted(closed & set(self._doors)))} "
                            "closed on the route; stopping to go round")  # fmt: skip
                self.executor.brake(now)
                self._restart = True
        if self._restart and self.executor.finished:
            if state.moving:
                return []
            self._traces.append(self.executor.trace)
            try:
                self.executor = self._plan(pose)
            except PlanningError as error:
                self.problem = str(error)
                return []
            self._restart = False
            self.replans += 1
            through = f" through {', '.join(self._doors)}" if self._doors else ""
            self.notify(f"{self.name}: new way, {self.executor.remaining():.1f} m{through}")
        commands = self.executor.step(now, state, pose)
        if self.executor.problem is not None:
            self.problem = self.executor.problem
        elif self.executor.finished and not self._restart:
            self._ended = now
        return commands

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        """The loop stops the robot; on resuming, the rest is planned from where it is."""
        self._paused = True

    def resume(self, now: float) -> None:
        if self._paused:
            self._paused = False
            self.executor.abandon()
            self._restart = True

    @property
    def finished(self) -> bool:
        return self._ended is not None

    @property
    def progress(self) -> str:
        """The room, a bar, the distance left and the time left, for the main view."""
        left = self.executor.remaining()
        total = max(self._total, left, 1e-9)
        filled = round(PROGRESS_BAR * (1 - left / total))
        bar = "█" * filled + "░" * (PROGRESS_BAR - filled)
        if self.finished:
            return f"{self.name}: arrived"
        state = " (paused)" if self._paused else " (replanning)" if self._restart else ""
        eta = self.executor.remaining_time(self._now)
        minutes, seconds = divmod(round(eta), 60)
        return f"{self.name} {bar} {left:.1f} m left, ETA {minutes}:{seconds:02d}{state}"

    def merged_trace(self) -> Trace:
        """What was commanded over every plan driven, one trace."""
        trace = Trace([], [])
        for each in [*self._traces, self.executor.trace]:
            trace.starts += [len(trace.times) + start for start in each.starts]
            trace.times += each.times
            trace.speeds += each.speeds
            trace.stops += each.stops
            trace.gear_jumps += each.gear_jumps
        return trace

    # -- inside -------------------------------------------------------------------------

    def _plan(self, pose: Pose) -> Executor:
        course = self._course(pose)
        legs = self.navigator.planner.legs if self.navigator is not None else None
        sections = shape(course.points, pose.heading, course.goal_heading,
                         legs.clear if legs is not None else None, self.turn_limits,
                         course.doorways)  # fmt: skip
        self.planned = course.planned
        self._doors = course.doors
        self._closed = self.navigator.state.closed if self.navigator is not None else frozenset()
        self._leg, self._leg_index = None, -1
        plan = self.navigator.plan if self.navigator is not None else None
        doors = [door.at for door in plan.doors if door.id in course.doors] if plan else []
        speed = self.limits.door_speed
        executor = Executor(
            sections, self.limits, self.tick, lambda drive: _door_zones(drive, doors, speed)
        )
        self._total = executor.remaining()
        return executor

    def _watch(self, now: float, pose: Pose) -> None:
        """Put what the range finder sees into the grid (while stopping too, so that the
        new plan knows all it can); if the grid now blocks the path ahead, stop and plan
        again (D* Lite across this room, else the room graph)."""
        readings = self._sense() if self._sense is not None else []
        points = [
            (pose.x + r * math.cos(pose.heading + b), pose.y + r * math.sin(pose.heading + b))
            for r, b in readings
        ]
        assert self.navigator is not None
        changes = self.navigator.report_obstacles(points)
        if changes:
            leg = self._current_leg(pose)
            if leg is not None:
                leg.update(changes)
        if self._restart or not self.navigator.state.obstacles:
            return
        if self._blocks_path_ahead():
            self.notify(f"{self.name}: something in the way ahead of ({pose.x:.1f}, "
                        f"{pose.y:.1f}); stopping to plan again")  # fmt: skip
            self.executor.brake(now)
            self._restart = True

    def _blocks_path_ahead(self) -> bool:
        """Whether the grid, as it now is, blocks the path within LOOKOUT_M ahead: of
        the drive under way, or of the next one after a turn on the spot."""
        legs = self.navigator.planner.legs if self.navigator is not None else None
        executor = self.executor
        if legs is None or executor.finished:
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
        return not all(legs.clear(a, b) for a, b in pairwise(points))

    def _current_leg(self, pose: Pose) -> Leg | None:
        """The D* Lite planner of the leg the robot is on, kept from one sighting to the
        next so that each replans incrementally."""
        if self.navigator is None or self.planned is None:
            return None
        legs = self.navigator.planner.legs
        route = self.planned.route
        if legs is None or len(route.path) < 2:
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


def _distance_to_segment(p: tuple[float, float], a: tuple[float, float],
                         b: tuple[float, float]) -> float:  # fmt: skip
    dx, dy = b[0] - a[0], b[1] - a[1]
    span = dx * dx + dy * dy
    t = 0.0 if span == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / span))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def _door_zones(drive: Drive, doors: list[tuple[float, float]], speed: float) -> list[SlowZone]:
    """Slow zones where the drive passes through the doors of its route."""
    zones = []
    step = 0.05
    count = max(2, math.ceil(drive.length / step) + 1)
    samples = [(i * drive.length / (count - 1)) for i in range(count)]
    poses = [drive.pose_at(s) for s in samples]
    for door in doors:
        distances = [math.hypot(p.x - door[0], p.y - door[1]) for p in poses]
        best = min(range(count), key=distances.__getitem__)
        if distances[best] <= DOOR_ZONE_M:
            at = samples[best]
            zones.append(SlowZone(max(0.0, at - DOOR_ZONE_M), min(drive.length, at + DOOR_ZONE_M),
                                  speed))  # fmt: skip
    return zones
