"""A survey: the robot maps the markers staff put up, and writes them into the plan
(issue 25, item 2; thesis §2.3.4).

"Staff stick printed markers where it suits them and write nothing down." A survey
starts on the dock (a pose the operator vouches for: the dock is the plan's start
room) and goes through the building: driven by the robot itself (`Tour`: a room at a
time, nearest first, looking round on the spot in each, back to the dock at the end)
or by the operator with the keys. Meanwhile the localisation logs the wheels and every
marker it sees (robot/survey_log.py) and learns the markers it does not know
(robot/marker_map.py), so that the robot finds its way by them as it goes; at the end
of each room's look round the pose graph (robot/pose_graph.py), solved on what the
survey has seen so far, redraws those markers and the robot's pose (`redraw_map`). A
room not reached (a way it could not pass, no marker it knew in sight) is tried once
more before the dock. At the end the pose graph estimates every marker's pose jointly
with the robot's whole path, each held to the plan's wall it hangs on
(robot/survey_walls.py), and the markers are written into the plan with their
uncertainty (`sigma`), where `go` and patrols find the robot by them from then on.

A marker seen fewer than MIN_SIGHTINGS times, or never square enough to see which way
it faces, is left out and named: one glimpse could be a misread id. A marker lies flat
on its wall, so one found on a wall of the plan sits on the wall's line and faces
square to it, as the plan's own checks ask (a solve held to a wall only softly left
one 2.2 degrees off, and the whole survey unwritten; another 3 cm into its wall, facing
into no room). One the plan's
checks still refuse is left out with their reason, and the others are written.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.path_mission import PathMission
from giraff_console.motion.executor import Executor
from giraff_console.motion.path import Rotation
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.planning.floorplan import FloorPlan, Landmarks, Marker
from giraff_console.planning.landmark_checks import landmark_problems
from giraff_console.planning.landmark_placement import DEFAULT_HEIGHT_M, write_landmarks
from giraff_console.planning.landmarks import (
    WALL_TOLERANCE_M,
    MarkerWalls,
    angle_between,
    marker_walls,
)
from giraff_console.planning.room_graph import PlanningError
from giraff_console.protocol.codec import Command
from giraff_console.robot.localisation import Localisation
from giraff_console.robot.marker_map import MarkerBelief, MarkerState
from giraff_console.robot.mission import Outcome, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph import SurveyedMarker, SurveyResult, Wall
from giraff_console.robot.survey_log import SurveyLog
from giraff_console.robot.survey_walls import solve_on_walls

Point = tuple[float, float]

# Sightings a marker needs to be written: one could be a misread id.
MIN_SIGHTINGS = 3
# A look round on the spot in each room: quarter turns, still between them long enough
# for a few sharp frames (missions/localising.py's PAUSE_S and then some).
LOOK_ROUND_STEP = math.pi / 2
STILL_S = 1.0
# A room not reached so leaves the robot standing where it can look round and go on: a
# way it could not pass, or no marker it knew in sight (the look round's sightings,
# redrawn with the survey's graph, may place it: `redraw_map`). Anything else (the board,
# a bad plan) ends the survey.
GOES_ON_AFTER = frozenset({Outcome.STALLED, Outcome.BLOCKED, Outcome.LOST})


def tour(plan: FloorPlan, rooms: list[str] | None = None) -> list[str]:
    """Every room (or `rooms`), nearest first (straight-line) from the start room, and
    back to it at the end."""
    start = plan.start
    assert start is not None, "a survey starts on the dock: the plan needs a start room"
    left = [room for room in (rooms or list(plan.rooms)) if room != start]
    here = plan.rooms[start].at
    order = []
    while left:
        room = min(left, key=lambda name: math.dist(here, plan.rooms[name].at))
        left.remove(room)
        order.append(room)
        here = plan.rooms[room].at
    return [*order, start]


class LookRound:
    """A Mission: looking four ways on the spot, three quarter turns apart, still for
    STILL_S at each, so that the camera's 90 degrees see every wall of the room (the
    survey's graph is best held where each room's markers are seen from one place:
    pose_graph's docs)."""

    def __init__(self, pose: Callable[[], Pose], limits: MotionLimits, tick: float) -> None:
        self.name = "look round"
        self.problem: str | None = None
        self._pose, self._limits, self._tick = pose, limits, tick
        self._turns = round(math.tau / LOOK_ROUND_STEP)
        self._executor: Executor | None = None
        self._still_since: float | None = None

    @property
    def finished(self) -> bool:
        return self._turns == 0 and self._executor is None

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if state is None or self.finished:
            return []
        if self._executor is not None:
            commands = self._executor.step(now, state, self._pose())
            if self._executor.problem is not None:
                self.problem = self._executor.problem
            if self._executor.finished and not state.moving:
                self._executor, self._still_since = None, now
            return commands
        if state.moving:
            return []
        if self._still_since is None:
            self._still_since = now
        if now - self._still_since < STILL_S:
            return []
        self._turns -= 1
        if self._turns == 0:
            return []
        here = self._pose()
        self._executor = Executor([Rotation(here, LOOK_ROUND_STEP)], self._limits, self._tick)
        return self._executor.step(now, state, here)

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        pass

    def resume(self, now: float) -> None:
        self._still_since = None

    @property
    def progress(self) -> Progress:
        return Progress(self.name, f"{self._turns} quarter turns left")


# The mission that drives to a room for the tour: a `go`, minding the estimate as the
# markers learnt so far keep it (steering against the casters, slow where unsure, looking
# round where lost: what a look sees is learnt too).
GoToRoom = Callable[[str], GoTo | PathMission]


@dataclass(frozen=True)
class Leg:
    """One room of the tour and how it went."""

    room: str
    outcome: Outcome | None
    why: str


class Tour:
    """A Mission: to each room of `rooms` in turn, looking round in each; a room not
    reached on the way (GOES_ON_AFTER) is tried once more before the last room, then
    left out, and the tour goes on (`legs` says how each try went, `not_reached` which
    rooms no try reached). A room the plan has no way to is left out at once."""

    def __init__(self, rooms: list[str], go: GoToRoom, pose: Callable[[], Pose],
                 limits: MotionLimits, tick: float,
                 notify: Callable[[str], None] = lambda text: None,
                 looked_round: Callable[[], None] = lambda: None) -> None:  # fmt: skip
        """`looked_round` is called at the end of each look round, the robot still
        (`redraw_map`)."""
        self.name = "survey"
        self.problem: str | None = None
        self.legs: list[Leg] = []
        self._rooms = list(rooms)
        self._go, self._pose, self._limits, self._tick = go, pose, limits, tick
        self._notify, self._looked_round = notify, looked_round
        self._leg: GoTo | PathMission | LookRound = LookRound(pose, limits, tick)
        self._room: str | None = None  # the room driven to, or None looking round
        self._tried_again: set[str] = set()

    @property
    def finished(self) -> bool:
        return not self._rooms and self._room is None and self._leg.finished

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self.finished or self.problem is not None:
            return []
        leg = self._leg
        commands = leg.step(now, state)
        if isinstance(leg, LookRound):
            if leg.problem is not None:
                self.problem = f"looking round: {leg.problem}"
            elif leg.finished:
                self._looked_round()
                self._next()
            return commands
        if leg.finished or leg.problem is not None:
            self.legs.append(Leg(str(self._room), leg.outcome, leg.problem or leg.detail))
            if leg.problem is not None:
                if leg.outcome not in GOES_ON_AFTER:
                    self._notify(f"survey: {self._room} not reached ({leg.problem})")
                    self.problem = f"{self._room}: {leg.problem}"
                    return commands
                self._notify(f"survey: {self._room} not reached ({leg.problem}); "
                             f"{self._again(str(self._room))}")  # fmt: skip
            self._room = None
            self._leg = LookRound(self._pose, self._limits, self._tick)
        return commands

    @property
    def not_reached(self) -> list[str]:
        """The rooms of the tour so far that no leg reached, in the tour's order."""
        reached = {leg.room for leg in self.legs if leg.outcome is not None and leg.outcome.arrived}
        return list(dict.fromkeys(leg.room for leg in self.legs if leg.room not in reached))

    def _again(self, room: str) -> str:
        """A room not reached is tried once more, before the tour's last room (the
        dock): by then the map knows more of the building, and the robot comes at it
        from elsewhere. What the survey does next, in words."""
        if room in self._tried_again:
            return "on to the next"
        self._tried_again.add(room)
        self._rooms.insert(max(0, len(self._rooms) - 1), room)
        return "trying it again before the end"

    def _next(self) -> None:
        while self._rooms:
            room = self._rooms.pop(0)
            try:
                self._leg, self._room = self._go(room), room
                return
            except PlanningError as error:
                self.legs.append(Leg(room, Outcome.BLOCKED, str(error)))
                self._notify(f"survey: no way to {room} ({error}); on to the next")

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        self._leg.pause(now)

    def resume(self, now: float) -> None:
        self._leg.resume(now)

    @property
    def progress(self) -> Progress:
        done = len(self.legs)
        where = f"to {self._room}" if self._room is not None else "looking round"
        state = f"{where}, {done} of {done + len(self._rooms) + (self._room is not None)} rooms"
        return Progress(self.name, state, detail=self._leg.progress)


def redraw_map(localisation: Localisation, walls: Sequence[Wall]) -> None:
    """The markers learnt so far, and the robot's pose, redrawn from the survey's graph
    solved on what it has logged (`walls`: the plan's, as `surveyed` holds markers to
    them): at the end of each room's look round, the robot standing still.

    Learnt on the way, a marker carries the robot's error where it was seen, and the
    robot, finding itself by such markers, keeps that error while its filter, counting
    each as news, grows sure of it: on the imperfect simulator a scanned home's survey
    was 15 cm off across a corridor with the filter believing itself within 2 cm, and
    clipped the frame of a 0.8 m door (10 cm to spare each side) on every try. The
    graph takes every sighting so far against the whole path and the plan's walls.

    Every marker the graph places is redrawn, so that none keeps the drift the robot has
    just been moved out of: known if it is known well enough, seen MIN_SIGHTINGS times
    and with its facing (as `surveyed` writes one), else back to being learnt. The
    robot's basis and its last fix are left as they were: the graph moves the pose, it
    does not vouch for it.

    It is solved on the loop's thread while the robot stands still (docs/performance.md
    gives its time), as the simulated camera is looked through there: a run on the
    virtual clock is then the same at any speed. A solve that fails or does not
    converge, or whose pose is not a pose, changes nothing and says so."""
    log = localisation.survey
    if log is None:
        return
    try:
        result = solve_on_walls(log.survey(), walls)
        np.linalg.cholesky(result.last_covariance)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as error:
        localisation.report(f"survey: the map so far could not be redrawn ({error}); going on "
                            "by the markers as learnt")  # fmt: skip
        return
    at = result.keyframes[-1]
    if not result.converged or not all(map(math.isfinite, (at.x, at.y, at.heading))):
        localisation.report("survey: the map so far did not settle; going on by the markers "
                            "as learnt")  # fmt: skip
        return
    markers = {}
    for marker_id, found in result.markers.items():
        belief = MarkerBelief(found.pose, found.covariance, MarkerState.LEARNING,
                              found.sightings)  # fmt: skip
        if found.facing_seen and found.sightings >= MIN_SIGHTINGS and belief.well_known:
            belief = replace(belief, state=MarkerState.KNOWN)
        markers[marker_id] = belief
    before = localisation.filter.pose
    # The last keyframe is where the robot stands: the log ends one there (survey_log.py).
    localisation.redraw(markers, at, result.last_covariance)
    moved = math.hypot(at.x - before.x, at.y - before.y)
    localisation.report(f"survey: map redrawn from {len(log.sightings)} sightings; the robot "
                        f"is {moved:.2f} m from where it was believed")  # fmt: skip


@dataclass(frozen=True)
class Surveyed:
    """What a survey found: the markers to write (with their uncertainty), those left
    out and why, and the solve's own figures."""

    landmarks: Landmarks
    left_out: dict[int, str]
    outliers: int
    result: SurveyResult


def plan_walls(plan: FloorPlan) -> list[Wall]:
    """The plan's walls a marker may hang on, as the survey's solver takes them."""
    return [Wall(segment.a, segment.b,
                 facing=None if segment.facing is None else math.radians(segment.facing))
            for segment in marker_walls(plan).segments]  # fmt: skip


def surveyed(plan: FloorPlan, log: SurveyLog, family: str, size: float) -> Surveyed:
    """The markers of a finished survey: solved on the plan's walls (a few seconds of
    CPU for a large building: not for the control loop's thread). A marker the plan
    has keeps its height, which the camera cannot measure well."""
    result = solve_on_walls(log.survey(), plan_walls(plan))
    heights = {marker.id: marker.height for marker in plan.landmarks.markers} \
        if plan.landmarks else {}  # fmt: skip
    walls = marker_walls(plan)
    markers, left_out = [], {}
    for marker_id, found in sorted(result.markers.items()):
        if found.sightings < MIN_SIGHTINGS:
            times = {1: "once", 2: "twice"}.get(found.sightings, f"{found.sightings} times")
            left_out[marker_id] = f"seen {times} (at least {MIN_SIGHTINGS} times)"
            continue
        if not found.facing_seen:
            left_out[marker_id] = "never seen square enough to tell which way it faces"
            continue
        at, facing = _onto_wall(found, walls)
        # As a file holds them: millimetres, tenths of a degree in [0, 360), no -0.
        markers.append(Marker(
            marker_id, (round(at[0], 3) + 0.0, round(at[1], 3) + 0.0),
            heights.get(marker_id, DEFAULT_HEIGHT_M), round(facing, 1) % 360,
            (round(max(found.sigma_m, 0.001), 3),
             round(max(math.degrees(found.sigma_facing), 0.1), 1)),
        ))  # fmt: skip
    refused = _refused(plan, family, size, markers)
    left_out.update(refused)
    kept = tuple(marker for marker in markers if marker.id not in refused)
    return Surveyed(Landmarks(family, size, kept), left_out, len(result.outliers),
                    result)  # fmt: skip


def _onto_wall(found: SurveyedMarker, walls: MarkerWalls) -> tuple[Point, float]:
    """Where a marker the survey `found` goes, flat on its wall (module docstring): on
    the nearest wall of the plan that runs behind it and that it faces out of (within
    45 degrees), if that is no further than WALL_TOLERANCE_M or, for one the solve held
    to a wall, two of its standard deviations across the wall; its facing then square
    out of it. As found (facing in degrees) if there is none, or if the solve found its
    sightings put it off the wall it was given. A scanned plan's walls are a grid's cell
    edges, many of them stubs: the wall the solve held the marker's facing to may be one
    beside it."""
    at, facing = (found.pose.x, found.pose.y), math.degrees(found.pose.heading)
    if not walls or found.wall_rejected:
        return at, facing
    normal = np.array([math.cos(found.pose.heading), math.sin(found.pose.heading)])
    across = math.sqrt(max(0.0, float(normal @ found.covariance[:2, :2] @ normal)))
    # Held to a wall by the solve, it is on one, within what the survey knows across it;
    # never held, it goes onto one only as near as a hand-measured marker would be.
    reach = max(WALL_TOLERANCE_M, 2.0 * across) if found.wall is not None else WALL_TOLERANCE_M
    a, d = walls.a, walls.d
    t = ((at[0] - a[:, 0]) * d[:, 0] + (at[1] - a[:, 1]) * d[:, 1]) / walls.span
    foot = a + np.clip(t, 0.0, 1.0)[:, None] * d
    off = np.hypot(at[0] - foot[:, 0], at[1] - foot[:, 1])
    # The wall's normal on the side the marker faces, and how far it is from square.
    sides = np.degrees(np.arctan2(d[:, 1], d[:, 0])) + 90.0
    sides = np.where(np.cos(np.radians(sides - facing)) < 0, sides + 180.0, sides)
    square = np.cos(np.radians(sides - facing)) >= math.cos(math.radians(45.0))
    outward = np.array([wall.facing is None or angle_between(side, wall.facing) <= 45.0
                        for wall, side in zip(walls.segments, sides, strict=True)])  # fmt: skip
    long = np.einsum("ij,ij->i", d, d) > 0.0
    behind = long & (t >= 0.0) & (t <= 1.0) & square & outward & (off <= reach)
    if not behind.any():
        return at, facing
    best = int(np.flatnonzero(behind)[np.argmin(off[behind])])
    return (float(foot[best, 0]), float(foot[best, 1])), float(sides[best]) % 360.0


def _refused(plan: FloorPlan, family: str, size: float,
             markers: list[Marker]) -> dict[int, str]:  # fmt: skip
    """The markers the plan's own checks refuse (the file would not load with them), by
    id, with why; of two that overlap, the second."""
    problems = landmark_problems(family, size, list(enumerate(markers)), plan)
    refused: dict[int, str] = {}
    for where, why in problems:
        if len(where) > 2 and where[:2] == ("landmarks", "markers") and isinstance(where[2], int):
            refused.setdefault(markers[where[2]].id, why)
    return refused


def write_surveyed(plan: FloorPlan, found: Surveyed, whole: bool) -> FloorPlan:
    """The surveyed markers written into the plan's file; the plan read back. A survey
    of the `whole` building replaces the plan's other markers (it saw what is on the
    walls now); one of some rooms keeps those it did not see."""
    landmarks = found.landmarks
    if not whole and plan.landmarks is not None:
        seen = {marker.id for marker in landmarks.markers}
        kept = [marker for marker in plan.landmarks.markers if marker.id not in seen]
        markers = tuple(sorted((*landmarks.markers, *kept), key=lambda marker: marker.id))
        landmarks = Landmarks(landmarks.family, landmarks.size, markers)
    return write_landmarks(plan, landmarks)
