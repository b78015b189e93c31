"""The thesis's way of moving, kept as the peer that `bench/motion.py` measures `go` against.

The original console had two kinds of move the board plans itself: a straight line
(style 0 < r <= 50, `p` in metres, A.2.1) and a rotation in place (r = 0, `p` in degrees,
positive to the right, A.2.2), each a trapezoid ramped by the board at `a` up to `v`
(A.1). Curves were the trouble: a curved move cannot be ended without stopping or
forcing `vgr` to zero, which jerks (§3.2.1.4). So this mission drives a planned polyline
the way that console could: at every waypoint it stops, turns on the spot to face the
next one, and drives straight there.

Each move is streamed in steps no longer than the console's reach, so that a console
that dies mid-move lets the robot run no further than that (missions/streamed_move.py).

`go` (missions/go_to.py) replaces all this with clothoid turns on a jerk-limited
profile; this mission exists so that the benchmark can show what that gains.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from itertools import pairwise

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.streamed_move import TURN_DONE_M, StreamedMove
from giraff_console.motion.path import wrap
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.protocol.codec import Command
from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.robot.mission import ARRIVED, Progress
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]

# Waypoints closer than this to the one before are the same waypoint.
MIN_LEG_M = 0.01
# Where the path turns by less than this the robot drives straight on: the thesis's
# console stopped only to turn, and the planner's doorway points lie on straight lines.
MIN_TURN_RAD = math.radians(1.0)


def corners(points: Sequence[Point]) -> list[Point]:
    """`points` without repeats and without the waypoints where the path does not turn."""
    kept: list[Point] = [points[0]]
    for point in points[1:]:
        if math.dist(point, kept[-1]) >= MIN_LEG_M:
            kept.append(point)
    turning = kept[:1]
    for point, after in pairwise(kept[1:]):
        before = turning[-1]
        turn = wrap(math.atan2(after[1] - point[1], after[0] - point[0])
                    - math.atan2(point[1] - before[1], point[0] - before[0]))  # fmt: skip
        if abs(turn) >= MIN_TURN_RAD:
            turning.append(point)
    if len(kept) > 1:
        turning.append(kept[-1])
    return turning


class WaypointDrive:
    """A Mission that stops at each waypoint, turns to face the next and drives to it."""

    def __init__(
        self,
        points: Sequence[Point],
        pose: Callable[[], Pose],
        *,
        goal_heading: float | None = None,
        name: str = "waypoints",
        limits: MotionLimits | None = None,
    ) -> None:
        """Drive along `points` from where the robot is (a first point there, as a
        planned path has, is the same waypoint), then turn to `goal_heading` (radians,
        counter-clockwise) if given."""
        here = pose()
        self.waypoints = corners([(here.x, here.y), *points])[1:]
        self.goal_heading = goal_heading
        self.name = name
        self.limits = limits or MotionLimits()
        self.problem: str | None = None
        # When the robot came to rest at each waypoint it went on from (clock seconds).
        self.stops: list[float] = []
        self._pose = pose
        self._index = 0  # the waypoint being driven to
        self._facing = False  # turned towards it (at the end: to the goal heading)
        self._move: StreamedMove | None = None
        self._resting_since: float | None = None  # arrived at a waypoint, not gone on yet
        self._paused = False
        self._finished = False

    @classmethod
    def to_room(cls, navigator: Navigator, room: str, pose: Callable[[], Pose],
                limits: MotionLimits | None = None) -> WaypointDrive:  # fmt: skip
        """The peer of `GoTo(navigator, room, ...)`: the same planned path and heading
        (PlanningError if there is no way)."""
        planned = navigator.go(room, pose())
        return cls(planned.path, pose, goal_heading=planned.goal_heading,
                   name=f"waypoints {room}", limits=limits)  # fmt: skip

    # -- the Mission protocol -----------------------------------------------------------

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self._paused or self._finished or state is None or self.problem is not None:
            return []
        if state.imdl is None or state.imdr is None:
            self.problem = "the board does not report wheel distances (imdl, imdr)"
            return []
        if self._move is None:
            if state.moving:
                return []  # still braking from a pause
            self._move = self._next_move(state)
            if self._move is None:
                self._finished = True
                return []
            if self._resting_since is not None:
                self.stops.append(self._resting_since)
                self._resting_since = None
        return self._continue(self._move, now, state)

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        """The loop stops the robot; on resuming, the move is made again from there."""
        self._paused = True

    def resume(self, now: float) -> None:
        if self._paused:
            self._paused = False
            # The move cut short is planned again from where the robot has stopped.
            self._move = None

    @property
    def finished(self) -> bool:
        return self._finished

    @property
    def progress(self) -> Progress:
        """The waypoint being driven to and the path left, for the main view."""
        if self._finished:
            return Progress(self.name, ARRIVED)
        count = len(self.waypoints)
        here = self._pose()
        path = [(here.x, here.y), *self.waypoints[self._index :]]
        left = sum(math.dist(a, b) for a, b in pairwise(path))
        at = min(self._index + 1, count)
        paused = " (paused)" if self._paused else ""
        return Progress(self.name, f"waypoint {at}/{count}{paused}", left)

    # -- inside -------------------------------------------------------------------------

    def _next_move(self, state: MotorState) -> StreamedMove | None:
        """From rest: turn to face the next waypoint, then drive to it; at the end, turn
        to the goal heading. None when there is nothing left to do."""
        pose = self._pose()
        base = (state.imdl or 0.0, state.imdr or 0.0)
        target = self.waypoints[self._index] if self._index < len(self.waypoints) else None
        if target is not None:
            aim = math.atan2(target[1] - pose.y, target[0] - pose.x)
        elif self.goal_heading is not None:
            aim = self.goal_heading
        else:
            return None
        if not self._facing:
            turn = wrap(aim - pose.heading)
            if abs(turn) * TURN_RADIUS_M > TURN_DONE_M:
                return self._new_move(True, -turn * TURN_RADIUS_M, base)
            self._facing = True
        if target is None:
            return None
        # Straight ahead as far as the waypoint lies along the heading: a straight move
        # cannot take out a sideways miss; the next turn aims from where it ends.
        dx, dy = target[0] - pose.x, target[1] - pose.y
        ahead = dx * math.cos(pose.heading) + dy * math.sin(pose.heading)
        return self._new_move(False, ahead, base)

    def _new_move(self, turning: bool, total: float, base: tuple[float, float]) -> StreamedMove:
        speed = self.limits.rotation_speed if turning else self.limits.v_max
        return StreamedMove(turning, total, base, speed, self.limits.a_max)

    def _continue(self, move: StreamedMove, now: float, state: MotorState) -> list[Command]:
        """This tick's commands for the move; once it is over, on to the next."""
        commands = move.step(state)
        if commands is not None:
            return commands
        self._move = None
        if move.turning:
            self._facing = True
        else:
            self._index += 1
            self._facing = False
            self._resting_since = now
        return []
