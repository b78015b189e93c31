"""Looking for a marker: what a mission does when it no longer knows well enough where
the robot is (issue 14, §2.3).

Between markers the pose filter (robot/ekf.py) runs on the odometry alone, and its
uncertainty grows with every metre and, most, with the casters' turn after each turn in
place (§3.2.1.5). A path mission watches the estimate (path_mission.py): past the slow
bound it drives slower, past the look bound it comes to a stop and looks, here: it turns
on the spot towards the markers the floor plan says it should be able to see from where
it believes it is, and stands still at each long enough for the camera to take a sharp
frame or two, until a marker has brought the uncertainty back under the bound. If none
does, it sweeps the rest of the circle; if that finds none either, the mission ends and
the operator is told.

The turns are turns on the spot of a motion executor (motion/executor.py), within the
mission's limits and sent as any mission's commands are, so that the control loop
checks them with the one guard. They are measured by the odometry's heading, not the
estimate's, which jumps when a marker corrects it part-way through a turn.

Which way to look first
    The markers it could read (planning/marker_sight.py), in the order that turns the
    robot least: from where it faces now to the marker, and from the marker to the way
    it will set off (`prefer`). Ending a
    look facing the way the path goes matters: the casters, swung round by the look's
    turns, turn the robot unseen over the first decimetres it drives (§3.2.1.5), and a
    marker still in view then corrects that; a small turn afterwards also charges them
    less. This is how a look does not lead straight into the next one.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Mapping, Sequence

from giraff_console.camera.marker_reach import STANDARD_SIZE_M
from giraff_console.link.motor_state import MotorState
from giraff_console.motion.executor import Executor, Trace
from giraff_console.motion.path import Rotation, wrap
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.marker_sight import visible_markers
from giraff_console.planning.walls import WallSegment
from giraff_console.protocol.codec import Command
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose

# The marker directions tried before sweeping the circle: more, and a robot whose
# estimate is wrong would turn back and forth between places that are not there.
CANDIDATES = 3
# The sweep's steps: the camera sees 90 degrees, so stops 60 degrees apart overlap.
SWEEP_STEP = math.radians(60.0)
# Still at each stop for this long: a frame needs about 0.2 s still to be sharp, and at
# the camera's 10 frames a second the rest brings a few more (§3.3).
PAUSE_S = 0.5
# A marker seen at a stop but the estimate not yet within the bound: more frames of it
# bring it down, for up to this long, before the look moves on.
GATHER_S = 2.0
# Stops nearer than this to a heading the robot has faced are not turned to again.
MIN_TURN = math.radians(3.0)
# A look's turn is near enough its stop within this, once its profile is over: the
# camera sees 90 degrees. The executor would go on to a fraction of a degree, and a
# board whose every move misses by a few millimetres (§5.5) can hunt back and forth
# round that for many seconds.
AIM = math.radians(2.0)


class Outcome(enum.Enum):
    FOUND = "found"  # a marker brought the estimate within the bound
    CORRECTED = "corrected"  # markers corrected it, but not within the bound
    NOT_FOUND = "not found"  # no marker seen all the way round


class Look:
    """Turn on the spot towards the markers, then round the circle, until `enough`
    says the estimate is good enough; see the module docstring. Stepped by a mission
    with the robot still at the start; `finished` once it has stopped turning, with
    its `outcome`."""

    def __init__(self, estimate: Estimate, markers: Mapping[int, Pose],
                 walls: Sequence[WallSegment], *, limits: MotionLimits, tick: float,
                 enough: Callable[[Estimate], bool], prefer: float | None = None,
                 why: str = "looking for a marker",
                 size: float = STANDARD_SIZE_M) -> None:  # fmt: skip
        """`prefer`: the heading (map frame) the robot will set off in afterwards;
        `why` what the mission's progress says it is doing; `size`: the markers'."""
        self.limits = limits
        self.tick = tick
        self.enough = enough
        self.why = why
        self.outcome: Outcome | None = None
        self.problem: str | None = None
        self.started_at: float | None = None
        self.traces: list[Trace] = []
        self.corrected = False
        # Stops are headings in the odometry's frame: the turns are measured by it.
        heading = estimate.odometry.heading
        to_odometry = heading - estimate.pose.heading
        after = heading if prefer is None else prefer + to_odometry
        here = (estimate.pose.x, estimate.pose.y)
        directions = [bearing + to_odometry
                      for _, bearing in visible_markers(markers, walls, here, size)]  # fmt: skip
        directions.sort(key=lambda d: abs(wrap(d - heading)) + abs(wrap(after - d)))
        # Where it faces comes first, without turning: a marker may be in view already.
        self._stops = directions[:CANDIDATES]
        self._looked: list[float] = []
        self._swept = False
        self._executor: Executor | None = None
        self._still_since: float | None = None
        self._stops_done = 0
        self._aim = 0.0  # the stop turned to, odometry frame
        self._turn_began = 0.0

    @property
    def finished(self) -> bool:
        return self.outcome is not None or self.problem is not None

    @property
    def state(self) -> str:
        """What the look is doing, as its mission's progress says: why it looks and how
        many directions it has looked in."""
        done = f"{self._stops_done} of {self._stops_done + len(self._stops)} directions"
        sweep = ", sweeping the circle" if self._swept else ""
        return f"{self.why} ({done}{sweep})"

    def step(self, now: float, state: MotorState, estimate: Estimate) -> list[Command]:
        if self.started_at is None:
            self.started_at = now
        if self.finished:
            return []
        corrected_at = estimate.corrected_at
        if estimate.found and corrected_at is not None and corrected_at >= self.started_at:
            self.corrected = True
        satisfied = self.corrected and self.enough(estimate)
        executor = self._executor
        if executor is not None:
            if self._settling(now, estimate.odometry.heading, satisfied):
                executor.abandon()  # the board ends its last few millimetres by itself
            elif satisfied:
                executor.brake(now)  # a turn on the spot is finished first
            commands = executor.step(now, state, estimate.odometry)
            if executor.problem is not None:
                self.problem = executor.problem
                return []
            if not executor.finished:
                return commands
            self._executor = None
            self._still_since = None  # once the robot is still
            return commands
        if satisfied:
            self.outcome = Outcome.FOUND
            return []
        if state.moving:
            self._still_since = None
            return []
        if self._still_since is None:
            self._still_since = now
        still = now - self._still_since
        seen_here = corrected_at is not None and corrected_at >= self._still_since
        if still < PAUSE_S or (seen_here and still < PAUSE_S + GATHER_S):
            return []
        return self._turn_to_next(now, state, estimate)

    def _turn_to_next(self, now: float, state: MotorState, estimate: Estimate) -> list[Command]:
        odometry = estimate.odometry
        heading = odometry.heading
        self._looked.append(heading)
        # A stop the robot has faced already has shown what it can.
        while self._stops and self._faced(self._stops[0], MIN_TURN):
            self._stops.pop(0)
        if not self._stops:
            self._stops = self._sweep(heading)
        if not self._stops:
            self.outcome = Outcome.CORRECTED if self.corrected else Outcome.NOT_FOUND
            return []
        self._stops_done += 1
        self._aim = self._stops.pop(0)
        self._turn_began = now
        rotation = Rotation(odometry, wrap(self._aim - heading))
        self._executor = Executor([rotation], self.limits, self.tick)
        self.traces.append(self._executor.trace)
        self._still_since = None
        return self._executor.step(now, state, odometry)

    def _settling(self, now: float, heading: float, satisfied: bool) -> bool:
        """Whether the turn under way has had its time and is only settling: on its stop
        near enough, or with no need of it any more."""
        assert self._executor is not None
        over = now - self._turn_began >= self._executor.profiles[0].duration
        return over and (satisfied or abs(wrap(self._aim - heading)) <= AIM)

    def _sweep(self, heading: float) -> list[float]:
        """Once: the rest of the circle, counter-clockwise from `heading` in SWEEP_STEP,
        but for what the stops so far have seen."""
        if self._swept:
            return []
        self._swept = True
        steps = round(math.tau / SWEEP_STEP)
        stops = [heading + i * math.tau / steps for i in range(1, steps)]
        return [stop for stop in stops if not self._faced(stop, SWEEP_STEP / 2)]

    def _faced(self, heading: float, within: float) -> bool:
        return any(abs(wrap(heading - seen)) <= within for seen in self._looked)
