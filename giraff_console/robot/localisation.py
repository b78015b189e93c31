"""Where the robot is: the odometry corrected by the markers the camera sees (§2.3).

The control loop owns one Localisation. On its thread, after every poll, `follow` hands
the pose filter (ekf.py) what the wheels did since the last poll; the camera, on its own
thread, hands `sighted` each frame's markers, and `correct` (the loop's thread again)
takes them in before the tick uses the pose. Everything that steered by the odometry's
pose steers by `pose`, the filter's estimate; the odometry's own stays beside it for
recordings and for comparison (`Estimate.odometry`).

Why a frame is moved to the present before it corrects anything
    A frame is taken a few tens of milliseconds, on a loaded PC a few hundred, before
    the loop gets its markers, and the robot has moved on meanwhile (30 cm/s is 3 cm a
    tenth of a second). Each sighting is carried from the frame's time to now by what
    the odometry did in between (interpolated between the polls either side of the
    frame), which over that short a time is good to millimetres.
    A frame older than `HISTORY_S` is dropped: the odometry between then and now is no
    longer kept, and so old a frame says little anyway.

No starting guess
    Where the robot starts is only ever as good as whoever said so, and the estimate
    says who did (`PoseBasis`): a marker, the operator (`place`, or a simulator
    started on its dock), or nobody (the pose kept on disk by
    a daemon that was restarted, or the dock merely assumed: `ASSUMED`). An assumed
    pose is never driven on beyond a look for a marker (missions/path_mission.py,
    issue 25). With markers, a start is not evidence either: until a marker has
    confirmed the pose (`found`), a sighting the gate rejects places the robot where
    the sighting says instead (the first marker seen places the robot: ids are unique
    in a plan). After that the gate holds, so that a marker moved on the wall but not
    in the plan cannot drag the estimate away.

How fresh a fix is
    The filter's uncertainty grows with every metre driven, but only by the noise it
    models: a robot that clips a door frame, or whose casters pull harder than modelled
    (§3.2.1.5), is further off than it says. So the estimate also counts the metres
    driven on the odometry alone since a marker last corrected it (`since_fix_m`), and
    whether the robot has touched something since (`contact`, from a stall): a mission
    claims arrival only on a fix recent enough for both (missions/certainty.py).

The pose when the odometry's jumps
    The odometry's pose jumps when its first-motion check replaces the wheel reading
    (odometry_feed.py). The filter follows the wheels, not that pose, so it would not
    see the jump; `follow` notices the odometry's pose is no longer where its own wheel
    steps put it and moves the estimate by the same change.
"""

from __future__ import annotations

import collections
import enum
import math
import queue
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from giraff_console.camera.marker_reach import STANDARD_SIZE_M, facing_reach, read_reach
from giraff_console.protocol.kinematics import BODY_RADIUS_M
from giraff_console.robot.ekf import FilterNoise, Observation, PoseFilter, wrap
from giraff_console.robot.marker_map import (
    LEARN_FROM_SIGMA_M,
    MarkerBelief,
    MarkerMap,
    Point,
    hand_covariance,
)
from giraff_console.robot.odometry import Odometry, Pose

if TYPE_CHECKING:  # the survey's log builds on this module's starting covariance
    from giraff_console.robot.survey_log import SurveyLog

# Sightings older than this are dropped (see the module docstring).
HISTORY_S = 1.0
# What counts as seen or rejected "recently", for the map and the top line.
RECENT_S = 5.0
# Where the robot is assumed to start, on its dock, as a standard deviation: a robot
# put on its dock by hand sits within a few centimetres and degrees.
START_SIGMA_M = 0.05
START_SIGMA_HEADING = math.radians(3.0)
# The bounds missions act on (missions/localising.py): past SLOW_SIGMA_M a mission slows
# down, past LOOK_SIGMA_M it stops and looks for a marker. The error at a stop is
# required to stay within 0.10 m (issue 14); a 2-sigma 0.10 m is a sigma of 0.05 m.
SLOW_SIGMA_M = 0.10
LOOK_SIGMA_M = 0.20
# A step whose centre moves less than this fraction of what its wheels turn is a turn
# in place, which leaves the casters out of line (§3.2.1.5).
IN_PLACE_FRACTION = 0.1
# Another marker corrected the pose this recently: it vouches for where the robot is,
# against a marker the gate keeps rejecting (marker_map.py, MOVED).
VOUCHED_S = 1.0
# A scan's fix is not fused into a position known better than this: the same walls
# matched again repeat their errors, and fused every 0.1 m the filter would soon believe
# itself to a centimetre (0.008 m after 3 m), finer than the map it is fitted to is
# drawn, and refuse a marker that is right (missions/scan_fixing.py). Within the gate,
# it still confirms the pose, and its heading corrects one known worse than it.
SCAN_FLOOR_M = 0.02


# After a contact (a stall against something) the pose may be off by what the robot was
# pushed, or by what the steering could not take out before it touched (CONTACT_PUSH_M,
# CONTACT_SLIP), and most by a pivot: a robot pushing on against a door frame it clipped
# swings about the frame while its wheels barely turn, 15 to 40 degrees on the imperfect
# simulator's scanned home (CONTACT_PIVOT is that as one sigma, half the worst). A pivot
# by an angle a about a point of the rim moves the centre by the radius times a, every
# way alike (the point is not known): a sigma of BODY_RADIUS_M * CONTACT_PIVOT / sqrt(2)
# each way. Allowed less, the next marker's sightings after a 20-degree pivot failed the
# gate, the robot planned its retry from the heading it believed, and clipped the same
# frame on every try (a survey left seven rooms out at one door).
CONTACT_PUSH_M = 0.05
CONTACT_SLIP = math.radians(5.0)
CONTACT_PIVOT = math.radians(20.0)
CONTACT_SIGMA_M = math.hypot(CONTACT_PUSH_M, BODY_RADIUS_M * CONTACT_PIVOT / math.sqrt(2))
CONTACT_SIGMA_HEADING = math.hypot(CONTACT_SLIP, CONTACT_PIVOT)


class PoseBasis(enum.Enum):
    """Who last said where the robot is; see the module docstring."""

    MARKER = "marker"  # a marker placed or confirmed it
    SCAN = "scan"  # the range sensor's scan, fitted to the plan's map, confirmed it
    GIVEN = "given"  # the operator: `place`, or a simulator started on its dock
    ASSUMED = "assumed"  # nobody: kept on disk by a restarted daemon, or the dock assumed

    @property
    def verified(self) -> bool:
        """Something other than an assumption says where the robot is."""
        return self is not PoseBasis.ASSUMED


@dataclass(frozen=True)
class Estimate:
    """Where the robot is believed to be, and how well that is known, as of one tick.

    `pose` is the filter's estimate (the odometry's own while the plan has no markers);
    `odometry` is dead reckoning alone. `covariance` is (x, y, heading)'s 3x3, row by
    row; `sigma_m` the position's standard deviation along its worst direction and
    `sigma_heading` the heading's (radians); `ellipse` the 1-sigma position ellipse:
    semi-major and semi-minor axes (metres) and the major axis's direction (radians
    from +x). `landmarks`: the plan has markers to find the robot by; `found`: a marker
    (or a range scan fitted to the plan's map) has placed or confirmed the pose since
    the start. `seen` and `rejected` are the ids of the markers used, and rejected by
    the gate, in the last RECENT_S seconds; `corrected_at` when a marker or a scan last
    corrected the pose, on the loop's clock."""

    pose: Pose
    odometry: Pose
    covariance: tuple[tuple[float, float, float], ...]
    sigma_m: float
    sigma_heading: float
    ellipse: tuple[float, float, float]
    landmarks: bool = False
    found: bool = False
    seen: tuple[int, ...] = ()
    rejected: tuple[int, ...] = ()
    corrected_at: float | None = None
    # The turn the casters have still to make since the last turn on the spot
    # (§3.2.1.5; ekf.py), released as the robot moves: its root mean square (radians),
    # and how fast they are expected to turn the robot now (radians per metre driven,
    # positive left), for drives to steer against.
    caster_pending: float = 0.0
    caster_rate: float = 0.0
    # Who said where the robot is, the metres its centre has driven on the odometry
    # alone since (a marker's correction, or the placing), and whether it has touched
    # something since (module docstring, "How fresh a fix is").
    basis: PoseBasis = PoseBasis.ASSUMED
    since_fix_m: float = 0.0
    contact: bool = False

    @property
    def lost(self) -> bool:
        """Known too loosely to drive on (LOOK_SIGMA_M), or never found, in a plan whose
        markers could tell; never without markers, where the odometry is all there is."""
        return self.landmarks and (not self.found or self.sigma_m > LOOK_SIGMA_M)

    @property
    def unsure(self) -> bool:
        """Known loosely enough to slow down for (SLOW_SIGMA_M), in a plan with markers."""
        return self.landmarks and (not self.found or self.sigma_m > SLOW_SIGMA_M)


@dataclass(frozen=True)
class PoseFix:
    """Where a range scan taken at `time` (the loop's clock) fits the plan's map: the
    robot's `pose` then, known to `covariance` (3x3: metres, radians); `pinned` if the
    scan's walls pinned it every way (not a corridor's, known across it only) and the
    heading was searched as far as it may be off."""

    time: float
    pose: Pose
    covariance: np.ndarray
    pinned: bool = True


def start_covariance() -> np.ndarray:
    return np.diag([START_SIGMA_M**2, START_SIGMA_M**2, START_SIGMA_HEADING**2])


class Localisation:
    """The pose filter, fed by the odometry and the camera's markers; see the module
    docstring. `follow`, `correct` and `estimate` are for the control loop's thread;
    `sighted` is safe from any thread."""

    def __init__(self, odometry: Odometry, markers: Mapping[int, Pose] | None = None,
                 now: Callable[[], float] = lambda: 0.0,
                 report: Callable[[str], None] = lambda text: None) -> None:  # fmt: skip
        self.odometry = odometry
        self.now = now
        self.report = report
        # Each marker's centre on its wall, the way its face looks, and how well both
        # are known (marker_map.py; planning's landmarks.marker_beliefs): the robot
        # layer knows nothing of floor plans.
        self.map = MarkerMap()
        # A survey under way (missions/survey.py): the wheels and the markers logged.
        self.survey: SurveyLog | None = None
        self.filter = PoseFilter(odometry.pose, start_covariance())
        self._noise = self.filter.noise
        self.found = False
        self.basis = PoseBasis.ASSUMED
        self.since_fix_m = 0.0
        self.contact = False
        self._wheels = odometry.wheels
        # Where the odometry's pose would be if it only moved by the wheel steps followed.
        self._odometry_pose = odometry.pose
        # (time, odometry pose) after each step followed, for moving frames to the present.
        self._history: collections.deque[tuple[float, Pose]] = collections.deque()
        self._sightings: queue.SimpleQueue[list[Observation]] = queue.SimpleQueue()
        self._fixes: queue.SimpleQueue[PoseFix] = queue.SimpleQueue()
        self._seen: dict[int, float] = {}
        self._rejected: dict[int, float] = {}
        self._unknown_reported: set[int] = set()
        # Sightings used and rejected, by marker, since the console started: what a
        # patrol's report and the localisation benchmark count.
        self.used: collections.Counter[int] = collections.Counter()
        self.rejections: collections.Counter[int] = collections.Counter()
        # The scans' fixes used and rejected by the gate, likewise.
        self.scan_fixes = collections.Counter[bool]()
        self.use_markers(markers or {})

    def casters_turn_up_to(self, worst: float) -> None:
        """The robot's casters turn it by up to `worst` radians after a turn on the spot:
        the thesis's 45 degrees (§3.2.1.5) unless told otherwise, none on the ideal
        simulator, whose robot would otherwise be steered against a turn it never
        makes. The filter's expectation, and its spread, scale with it (ekf.py)."""
        thesis = FilterNoise()
        scale = worst / thesis.caster_worst
        self._noise = replace(self._noise, caster_worst=worst,
                              caster_sigma=thesis.caster_sigma * scale)  # fmt: skip
        self.use_markers(self.map.beliefs, self.marker_size)

    @property
    def markers(self) -> dict[int, Pose]:
        """The markers known well enough to find the robot by, and where they hang."""
        return self.map.known()

    def use_markers(self, markers: Mapping[int, Pose | MarkerBelief],
                    size: float = STANDARD_SIZE_M) -> None:  # fmt: skip
        """Find the robot by these markers, printed `size` metres across, from now on
        (none: by the odometry alone); a bare pose is a marker put up with a tape
        measure.

        Without markers the casters' turn is expected to be none on average, only
        uncertain: nothing would ever check the turn expected after each turn on the
        spot, and a robot whose casters pull less than the thesis's (or the ideal
        simulator's, which has none) would be steered off by it for good. The estimate
        is then the odometry's, and missions drive as they did before the filter."""
        beliefs = {marker_id: marker if isinstance(marker, MarkerBelief)
                   else MarkerBelief(marker, hand_covariance())
                   for marker_id, marker in markers.items()}  # fmt: skip
        self.map = MarkerMap(beliefs, noise=self._noise, learn_new=self.survey is not None)
        self.marker_size = size
        self._place_reach, self._facing_reach = read_reach(size), facing_reach(size)
        self._expect_casters()

    def start_survey(self, log: SurveyLog, walls: Sequence[tuple[Point, Point]] = ()) -> None:
        """Log the wheels and every marker seen into `log` from now on, and learn the
        markers the map does not have (missions/survey.py), held to the plan's `walls`
        (their ends) where they hang on one (marker_map.py)."""
        self.survey = log
        self.map.learn_new = True
        self.map.walls = np.array(walls, dtype=float).reshape(-1, 2, 2)
        self._expect_casters()

    def redraw(self, markers: Mapping[int, MarkerBelief], at: Pose,
               covariance: np.ndarray) -> None:  # fmt: skip
        """A survey's graph, solved on what it has logged so far, says where `markers`
        hang and that the robot is `at`, known to `covariance`: the map takes them in
        place of what it learnt on the way, and the estimate moves there, the casters'
        turn to come kept (missions/survey.py says when, and why)."""
        self.map.redraw(markers)
        self.filter.relocate(at, covariance)

    def end_survey(self) -> SurveyLog | None:
        """Stop logging; the log, if a survey was under way."""
        log, self.survey = self.survey, None
        self.map.learn_new = False
        self._expect_casters()
        return log

    def _expect_casters(self) -> None:
        """The casters' turn expected after a turn on the spot: the thesis's share while
        markers (or a survey's graph) can check it, else none (see use_markers)."""
        checked = bool(self.map) or self.survey is not None
        share = self._noise.caster_share if checked else 0.0
        self.filter.noise = replace(self._noise, caster_share=share)

    # -- from any thread ----------------------------------------------------------------

    def sighted(self, sightings: Iterable[Observation]) -> None:
        """One frame's markers, each with the frame's time on the loop's clock."""
        frame = list(sightings)
        if frame:
            self._sightings.put(frame)

    def scan_fitted(self, fix: PoseFix) -> None:
        """A range scan fitted to the plan's map (missions/scan_fixing.py)."""
        self._fixes.put(fix)

    # -- on the loop's thread -----------------------------------------------------------

    def place(self, pose: Pose, covariance: np.ndarray | None = None,
              basis: PoseBasis = PoseBasis.ASSUMED) -> None:  # fmt: skip
        """The robot is at `pose`, as `basis` says (the operator, or only an
        assumption: the console starting, a daemon restarted from the pose it kept): the
        odometry and the estimate start again from there."""
        self.odometry.reset(pose, self.odometry.reference)
        self.filter.reset(pose, start_covariance() if covariance is None else covariance)
        self._odometry_pose = pose
        self._wheels = self.odometry.wheels
        self._history.clear()
        self._history.append((self.now(), pose))
        while not self._fixes.empty():  # fitted round the pose before
            self._fixes.get_nowait()
        self.found = False
        self.basis = basis
        self.since_fix_m = 0.0
        self.contact = False

    def touched(self) -> None:
        """The robot has stalled against something (a mission's contact): the estimate
        is less sure than the filter thinks, and its fix is no longer fresh."""
        self.contact = True
        extra = np.diag([CONTACT_SIGMA_M**2, CONTACT_SIGMA_M**2, CONTACT_SIGMA_HEADING**2])
        self.filter.inflate(extra)
        if self.survey is not None:
            self.survey.touched(extra)

    def follow(self) -> None:
        """Predict by what the wheels did since the last call (see the module docstring
        for the odometry's jumps)."""
        odometry = self.odometry
        left = odometry.wheels[0] - self._wheels[0]
        right = odometry.wheels[1] - self._wheels[1]
        self._wheels = odometry.wheels
        if left or right:
            base = odometry.wheel_base
            centre = abs(left + right) / 2
            in_place = centre < IN_PLACE_FRACTION * max(abs(left), abs(right))
            self.filter.predict(left, right, base, turned_in_place=in_place)
            self._odometry_pose = _step(self._odometry_pose, left, right, base)
            self.since_fix_m += abs(left + right) / 2
            if self.survey is not None:
                self.survey.wheels(left, right, turned_in_place=in_place)
        jump = _between(self._odometry_pose, odometry.pose)
        if math.hypot(jump.x, jump.y) > 1e-6 or abs(jump.heading) > 1e-6:
            self.filter.move_to(_compose(self.filter.pose, jump))
            self._odometry_pose = odometry.pose
        now = self.now()
        self._history.append((now, odometry.pose))
        while self._history and self._history[0][0] < now - HISTORY_S:
            self._history.popleft()

    def correct(self) -> None:
        """Take in the scans' fixes and the markers seen since the last call, each moved
        to the present."""
        since = self.now() - RECENT_S
        for recent in (self._seen, self._rejected):
            for marker_id in [i for i, at in recent.items() if at < since]:
                del recent[marker_id]
        while True:
            try:
                fix = self._fixes.get_nowait()
            except queue.Empty:
                break
            self._take_fix(fix)
        while True:
            try:
                frame = self._sightings.get_nowait()
            except queue.Empty:
                return
            present = [seen for seen in map(self._take, frame) if seen is not None]
            if self.survey is not None and present:
                self.survey.frame(present)

    def _take(self, sighting: Observation) -> Observation | None:
        """One sighting, moved to the present: it corrects the pose (a known marker),
        places it (not found yet), or refines the marker (one being learnt). Returns it
        as moved, for a survey's log; None for one that says nothing."""
        marker_id = sighting.marker_id
        belief = self.map.beliefs.get(marker_id)
        if belief is None and not self.map.learn_new:
            if marker_id not in self._unknown_reported and self.map:
                self._unknown_reported.add(marker_id)
                self.report(f"marker {marker_id} seen, but the floor plan has no such "
                            "marker: ignored")  # fmt: skip
            return None
        now = self.now()
        present = self._to_present(sighting, now)
        if present is None:
            return None
        known = self.map.usable(marker_id)
        if known is None:
            # Not to find the robot by (yet): learnt from where the robot is known to be.
            note = self.map.learn(marker_id, self.filter.pose, self.filter.covariance, present)
            if note is not None:
                self.report(note)
            return present
        far = present.distance_m > self._facing_reach
        if far and self.found and present.facing_rad is not None:
            # Far off, a marker's facing is the weak part of its pose, and not only
            # noisy (camera/marker_reach.py); its distance and bearing are good to
            # centimetres and hundredths of a degree there. A robot not found yet keeps
            # it: placing the robot needs it, and only a marker within reach places.
            present = replace(present, facing_rad=None)
        # Until the robot is found, only a marker near enough to be read well confirms
        # or places it (camera/marker_reach.py's read_reach: 4 m for a 16 cm marker): a
        # farther one waits for a nearer (a look turns to them, nearer first).
        near = present.distance_m <= self._place_reach
        if not self.found and not near:
            return present  # too weak to confirm the assumed start by, or to place the robot
        sigma = known.covariance
        placeable = present.facing_rad is not None and known.placeable
        if not self.found and not self.basis.verified and placeable:
            # Only assumed (a restart's kept pose, or the dock taken for granted): no
            # evidence to weigh the marker against, and fused with it the assumption
            # would pull the first fix its way and vouch for it. The marker places it.
            return self._placed_by(marker_id, present, known.pose, sigma, now)
        if self.filter.correct(present, known.pose, sigma):
            self.map.accepted(marker_id)
            if not self.found:
                pose = self.filter.pose
                self.report(f"found by marker {marker_id}: at x={pose.x:.2f} y={pose.y:.2f}, "
                            "where it was believed to be")  # fmt: skip
            self._fixed(marker_id, now)
            return present
        if not self.found and placeable:
            # Not found yet, and the start it was given disagrees: this marker places it.
            return self._placed_by(marker_id, present, known.pose, sigma, now)
        self._rejected[marker_id] = now
        self.rejections[marker_id] += 1
        note = self.map.rejected(marker_id, self._vouched_for(marker_id, now))
        if note is not None:
            self.report(note)
        return present

    def _take_fix(self, fix: PoseFix) -> None:
        """A scan's fix, moved to the present, corrects the pose. A scan is fitted to
        the map only near where the robot was believed to be (the matcher's lattice,
        planning/scan_matching.py), and a building has many places alike: it confirms a
        pose somebody has said, never places one only assumed (a restarted daemon's),
        and in a plan with markers it never stands for one (`found`: until a marker has
        confirmed the pose, one that disagrees places the robot). Only a pinned fix
        makes the fix fresh again, and after a contact vouches for the pose."""
        if not self.basis.verified:
            return
        then = self._odometry_at(fix.time)
        if then is None:
            return
        present = _compose(fix.pose, _between(then, self.odometry.pose))
        f = self.filter
        if f.sigma_m >= SCAN_FLOOR_M:
            used = f.correct_pose(present, fix.covariance, self.now())
        elif fix.pinned and f.sigma_heading**2 > fix.covariance[2, 2]:
            # The position known better than the map, the heading not: the casters'
            # turn after a turn on the spot (§3.2.1.5) comes over the next decimetres,
            # unseen by the wheels, and may be 10 to 15 degrees more or less than
            # expected while the position is known to 2 cm. Left to the filter, the
            # robot drove its run in to a 0.8 m door 14 degrees off its line, and its
            # lidar saw the jamb 0.2 m into the doorway (tests/lidar's doorway drawn
            # off, on a busy machine). A pinned fix only: one whose heading search was
            # cut short (missions/scan_fixing.py) may have stopped at its edge.
            used = f.correct_heading(present, fix.covariance, self.now())
        else:
            used = f.agrees(present, fix.covariance)
        self.scan_fixes[used] += 1
        if not used:
            return
        self.basis = PoseBasis.SCAN
        if not self.map.known():
            self.found = True
        if fix.pinned:
            self.since_fix_m = 0.0
            self.contact = False

    def _placed_by(self, marker_id: int, present: Observation, at: Pose,
                   sigma: np.ndarray, now: float) -> Observation:  # fmt: skip
        """The robot placed where marker `marker_id`, hanging at `at`, says it is."""
        pose = self.filter.place_from(present, at, sigma)
        self._fixed(marker_id, now)
        self.report(f"found by marker {marker_id}: at x={pose.x:.2f} y={pose.y:.2f}")
        return present

    def _vouched_for(self, marker_id: int, now: float) -> bool:
        """Other markers have just corrected the pose, and it is known well."""
        others = any(at >= now - VOUCHED_S for i, at in self._seen.items() if i != marker_id)
        return others and self.filter.sigma_m <= LEARN_FROM_SIGMA_M

    def _fixed(self, marker_id: int, now: float) -> None:
        """A marker has placed or corrected the pose: it is found, and fixed afresh."""
        self.found = True
        self.basis = PoseBasis.MARKER
        self.since_fix_m = 0.0
        self.contact = False
        self._seen[marker_id] = now
        self.used[marker_id] += 1

    def _to_present(self, sighting: Observation, now: float) -> Observation | None:
        """The sighting as a camera at the robot's pose now would make it."""
        then = self._odometry_at(sighting.time)
        if then is None:
            return None
        moved = _between(then, self.odometry.pose)  # in the frame's robot frame
        # The marker in the robot's frame at the frame's time, then now.
        mx = sighting.distance_m * math.cos(sighting.bearing_rad) - moved.x
        my = sighting.distance_m * math.sin(sighting.bearing_rad) - moved.y
        cos_t, sin_t = math.cos(moved.heading), math.sin(moved.heading)
        x, y = cos_t * mx + sin_t * my, -sin_t * mx + cos_t * my
        facing = sighting.facing_rad
        return replace(
            sighting,
            distance_m=math.hypot(x, y),
            bearing_rad=math.atan2(y, x),
            facing_rad=None if facing is None else wrap(facing - moved.heading),
            time=now,
        )

    def _odometry_at(self, time: float) -> Pose | None:
        """The odometry's pose at `time`, between the two steps kept either side of it
        (a frame falls between two polls); None if out of reach."""
        history = self._history
        if not history or not math.isfinite(time) or time < history[0][0] - 1e-9:
            return None
        before_at, before = history[0]
        for at, pose in history:
            if at > time:
                share = (time - before_at) / (at - before_at)
                move = _between(before, pose)
                return _compose(before, Pose(move.x * share, move.y * share,
                                             move.heading * share))  # fmt: skip
            before_at, before = at, pose
        return before

    def estimate(self) -> Estimate:
        """The estimate now. Safe from another thread as a snapshot: it only reads."""
        since = self.now() - RECENT_S
        # Copied before they are read: the loop's thread may add to them meanwhile.
        seen = tuple(sorted(i for i, at in self._seen.copy().items() if at >= since))
        rejected = tuple(sorted(i for i, at in self._rejected.copy().items() if at >= since))
        f = self.filter
        covariance = f.covariance
        return Estimate(
            pose=f.pose,
            odometry=self.odometry.pose,
            covariance=tuple(tuple(float(v) for v in row) for row in covariance),  # type: ignore[misc]
            sigma_m=f.sigma_m,
            sigma_heading=f.sigma_heading,
            ellipse=f.ellipse(),
            landmarks=bool(self.map.known()),
            found=self.found,
            seen=seen,
            rejected=rejected,
            corrected_at=f.corrected_at if self.found else None,
            caster_pending=f.caster_pending,
            caster_rate=f.caster_rate,
            basis=self.basis,
            since_fix_m=self.since_fix_m,
            contact=self.contact,
        )

    @property
    def pose(self) -> Pose:
        return self.filter.pose


def _step(pose: Pose, left: float, right: float, wheel_base: float) -> Pose:
    """`pose` moved by the wheels' travel, as Odometry.update integrates it."""
    distance = (left + right) / 2
    turn = (right - left) / wheel_base
    mid = pose.heading + turn / 2
    return Pose(pose.x + distance * math.cos(mid), pose.y + distance * math.sin(mid),
                pose.heading + turn)  # fmt: skip


def _between(a: Pose, b: Pose) -> Pose:
    """`b` in `a`'s frame: the move from a to b as the robot at a sees it."""
    dx, dy = b.x - a.x, b.y - a.y
    cos_a, sin_a = math.cos(a.heading), math.sin(a.heading)
    return Pose(cos_a * dx + sin_a * dy, -sin_a * dx + cos_a * dy, wrap(b.heading - a.heading))


def _compose(a: Pose, move: Pose) -> Pose:
    """`a` moved by `move`, given in a's frame."""
    cos_a, sin_a = math.cos(a.heading), math.sin(a.heading)
    return Pose(a.x + cos_a * move.x - sin_a * move.y, a.y + sin_a * move.x + cos_a * move.y,
                a.heading + move.heading)  # fmt: skip
