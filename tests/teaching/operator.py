"""A person at the keyboard, scripted: drives the robot through a building room by room
with the arrow keys, as the console's teleop takes them (key repeats every 33 ms),
and types `mark ROOM` in each room (issue 29, "a scripted teleop drive").

The person watches the robot, so the script steers by where it really is (the
simulator's true pose): that is the person's eyes, not the console's knowledge. The
way it follows is planned on the true building (the person knows it), room point to
room point; it is steered as a person steers with keys: turning on the spot when the
way lies well off the nose, curving (the diagonal keys) when a little off, straight
on otherwise, and letting go at each room to stand and mark it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

from giraff_console.planning.floorplan import FloorPlan, Point
from giraff_console.planning.route_planner import RoutePlanner, walls_of
from giraff_console.robot.deadman import Intent
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service.events import Reply

REPEAT_S = 0.033  # a terminal's key repeat
SPEED = 0.25  # m/s: slow enough for a person to steer through a 0.8 m door by keys
LOOK_AHEAD_M = 0.35  # the point on the way the person steers for
TURN_ON_SPOT_DEG = 20.0  # off the nose by more: turn on the spot first
CURVE_DEG = 6.0  # off by more: the diagonal keys
THERE_M = 0.12  # close enough to a room's point to stop and mark it
SETTLE_S = 1.0  # let go, and wait this long for the robot to stand
# Pressing on without getting anywhere (a door frame clipped): back off a little.
STUCK_S, STUCK_M, BACK_OFF_S = 1.5, 0.02, 0.6


@dataclass
class Drive:
    """How the drive went: the rooms marked, and the replies to `mark`."""

    marked: list[str] = field(default_factory=list)
    replies: list[Reply] = field(default_factory=list)
    metres: float = 0.0
    seconds: float = 0.0


def tour(building: FloorPlan, rooms: Sequence[str]) -> list[tuple[str, list[Point]]]:
    """The way through `rooms` in turn on the true building: for each room, the
    polyline from the one before to it (the first from the building's start)."""
    planner = RoutePlanner(building, walls_of(building))
    start = building.start
    assert start is not None
    legs = []
    here = start
    for room in rooms:
        if room != here:
            legs.append((room, list(planner.between_rooms(here, room).path)))
        else:
            legs.append((room, [building.rooms[room].at]))
        here = room
    return legs


class Operator:
    """Holds the keys of `robot`'s own console (the service, in this process)."""

    def __init__(self, robot: Robot, timeout_s: float) -> None:
        self.robot = robot
        self.deadline = time.monotonic() + timeout_s

    def drive(self, legs: list[tuple[str, list[Point]]], mark: bool = True) -> Drive:
        drive = Drive()
        self.robot.service.execute(c.Speed(to=SPEED))
        started = time.monotonic()
        for room, way in legs:
            drive.metres += self._follow(way)
            if mark:
                reply = self.robot.service.execute(c.Mark(room))
                drive.replies.append(reply)
                if reply.ok:
                    drive.marked.append(room)
        drive.seconds = time.monotonic() - started
        return drive

    def _follow(self, way: list[Point]) -> float:
        """Along `way` to its end; the metres driven (truly)."""
        service = self.robot.service
        last = self._where()
        metres = 0.0
        goal = way[-1]
        moved_at, moved_from = time.monotonic(), last
        while True:
            self._in_time()
            x, y, heading = self._where()
            metres += math.dist(last[:2], (x, y))
            last = (x, y, heading)
            if math.dist((x, y), goal) <= THERE_M:
                break
            now = time.monotonic()
            turned = abs(math.remainder(heading - moved_from[2], math.tau))
            if math.dist((x, y), moved_from[:2]) > STUCK_M or turned > math.radians(3):
                moved_at, moved_from = now, last
            elif now - moved_at > STUCK_S:
                self._hold(Intent.BACKWARD, BACK_OFF_S)
                moved_at, moved_from = time.monotonic(), self._where()
                continue
            target = _look_ahead(way, (x, y), LOOK_AHEAD_M)
            off = math.degrees(
                math.remainder(math.atan2(target[1] - y, target[0] - x) - heading, math.tau)
            )
            service.execute(c.Press(_key(off)))
            time.sleep(REPEAT_S)
        # Let go, and stand.
        time.sleep(SETTLE_S)
        return metres

    def _hold(self, key: Intent, seconds: float) -> None:
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            self.robot.service.execute(c.Press(key))
            time.sleep(REPEAT_S)

    def _where(self) -> tuple[float, float, float]:
        pose = self.robot.true_pose()
        assert pose is not None, "the operator watches a simulated robot"
        return pose.x, pose.y, pose.heading

    def _in_time(self) -> None:
        if time.monotonic() > self.deadline:
            self.robot.service.execute(c.Halt())
            raise AssertionError("the scripted drive ran out of time")


def _key(off_deg: float) -> Intent:
    """The key a person presses for a way `off_deg` to the left (negative: right)."""
    if abs(off_deg) > TURN_ON_SPOT_DEG:
        return Intent.LEFT if off_deg > 0 else Intent.RIGHT
    if abs(off_deg) > CURVE_DEG:
        return Intent.FORWARD_LEFT if off_deg > 0 else Intent.FORWARD_RIGHT
    return Intent.FORWARD


def _look_ahead(way: list[Point], at: Point, reach: float) -> Point:
    """The point `reach` along `way` beyond the point of it nearest `at`."""
    if len(way) == 1:
        return way[0]
    best, best_d, best_s = 0, math.inf, 0.0
    for i in range(len(way) - 1):
        (ax, ay), (bx, by) = way[i], way[i + 1]
        dx, dy = bx - ax, by - ay
        length2 = dx * dx + dy * dy
        s = (
            0.0
            if length2 == 0
            else max(0.0, min(1.0, ((at[0] - ax) * dx + (at[1] - ay) * dy) / length2))
        )
        d = math.dist(at, (ax + s * dx, ay + s * dy))
        if d < best_d:
            best, best_d, best_s = i, d, s
    left = reach
    i, s = best, best_s
    while i < len(way) - 1:
        (ax, ay), (bx, by) = way[i], way[i + 1]
        length = math.dist((ax, ay), (bx, by))
        rest = (1 - s) * length
        if rest >= left and length > 0:
            t = s + left / length
            return ax + t * (bx - ax), ay + t * (by - ay)
        left -= rest
        i, s = i + 1, 0.0
    return way[-1]
