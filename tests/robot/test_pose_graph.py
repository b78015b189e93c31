"""The survey's pose graph (robot/pose_graph.py and its siblings) on synthetic buildings: no
simulator, fixed seeds.

A building here is a corridor along +x with square rooms either side, each with a door
onto it; markers hang on the corridor's walls and on every wall of every room. A survey
drives from the dock along the corridor, into each room, round it, and back to the
dock, turning on the spot at every corner, and the casters turn the robot after each
turn as the thesis's did (§3.2.1.5). The wheels read with the EKF's noise, the camera
(90 degrees wide, as the simulator's) reports every marker in view with the EKF's
measurement noise, and now and then misreads an id.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from functools import cache
from statistics import NormalDist

import numpy as np
import pytest

from giraff_console.robot import pose_graph
from giraff_console.robot.ekf import CHI_SQUARE, FilterNoise, Observation, PoseFilter, wrap
from giraff_console.robot.localisation import (
    CONTACT_SIGMA_HEADING,
    CONTACT_SIGMA_M,
    Localisation,
    start_covariance,
)
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.pose_graph import (
    CasterTurn,
    OdometryEdge,
    PosePrior,
    Sighting,
    Survey,
    SurveyedMarker,
    SurveyResult,
    Wall,
    marker_from_sighting,
    solve_survey,
)
from giraff_console.robot.pose_graph_model import whiteners
from giraff_console.robot.pose_graph_solve import outliers
from giraff_console.robot.survey_log import KEYFRAME_TRAVEL_M, SurveyLog
from giraff_console.robot.survey_walls import assign_walls, solve_on_walls

WHEEL_BASE = 0.499
DOCK = Pose(0.5, 0.0, 0.0)
ROOM_M = 4.0  # rooms are square, the corridor between them 2 m wide
DOOR_HALF_M = 0.45
FIELD_OF_VIEW = math.radians(45)  # either side: the simulator's camera is 90 degrees wide
READ_FROM = math.radians(65)  # a marker is read from within this of its normal
REACH_M = 4.5  # a 16 cm marker is a dozen pixels across at 4.5 m


class Building:
    """`rooms` rooms a side. Each room has a marker on each wall, the corridor one on
    each wall per room; `markers` holds their true poses (x, y, facing), `space` where
    each can be seen from (0 the corridor, then each room), `walls` the wall each hangs
    on, and `plan` the floor plan's walls: every room's outline, cut at its door, so
    that a wall between two rooms is there once for each (as planning/walls.py's)."""

    def __init__(self, rooms: int) -> None:
        self.rooms = rooms
        poses, spaces, walls = [], [], []

        def hang(x: float, y: float, facing: float, space: int, a: tuple[float, float],
                 b: tuple[float, float]) -> None:  # fmt: skip
            poses.append((x, y, facing))
            spaces.append(space)
            walls.append(Wall(a, b))

        for i in range(rooms):
            x0 = ROOM_M * i
            hang(x0 + 0.8, 1.0, -math.pi / 2, 0, (x0, 1.0), (x0 + 1.55, 1.0))
            hang(x0 + 3.2, -1.0, math.pi / 2, 0, (x0 + 2.45, -1.0), (x0 + 4, -1.0))
            for side, space in ((1, 1 + 2 * i), (-1, 2 + 2 * i)):
                far, near = side * 5.0, side * 1.0
                hang(x0 + 1.3, far, -side * math.pi / 2, space, (x0, far), (x0 + 4, far))
                hang(x0, side * 3.2, 0.0, space, (x0, near), (x0, far))
                hang(x0 + 4, side * 2.4, math.pi, space, (x0 + 4, near), (x0 + 4, far))
                hang(x0 + 3.2, near, side * math.pi / 2, space, (x0 + 2.45, near), (x0 + 4, near))
        self.markers = np.array(poses)
        self.space = np.array(spaces)
        self.walls = walls
        self.plan = self._plan()

    def _plan(self) -> list[Wall]:
        walls: list[Wall] = []
        length = ROOM_M * self.rooms

        def along_x(y: float, x0: float, x1: float, doors: list[float]) -> None:
            at = x0
            for door in doors:
                walls.append(Wall((at, y), (door - DOOR_HALF_M, y)))
                at = door + DOOR_HALF_M
            walls.append(Wall((at, y), (x1, y)))

        doors = [ROOM_M * i + 2 for i in range(self.rooms)]
        for y in (-1.0, 1.0):
            along_x(y, 0.0, length, doors)
        walls += [Wall((0.0, -1.0), (0.0, 1.0)), Wall((length, -1.0), (length, 1.0))]
        for i in range(self.rooms):
            x0 = ROOM_M * i
            for near, far in ((1.0, 5.0), (-1.0, -5.0)):
                along_x(near, x0, x0 + 4, [x0 + 2])
                along_x(far, x0, x0 + 4, [])
                walls += [Wall((x0, near), (x0, far)), Wall((x0 + 4, near), (x0 + 4, far))]
        return walls

    def space_of(self, x: float, y: float) -> int:
        if abs(y) <= 1.0:
            return 0
        i = min(self.rooms - 1, max(0, int(x // ROOM_M)))
        return 1 + 2 * i if y > 0 else 2 + 2 * i

    def route(self, look: bool) -> list[tuple[float, float] | None]:
        """Waypoints from the dock through every room and back; None: a full turn on the
        spot. One at the dock first, so that the way back sees markers seen then (else
        the last turn's casters are measured by nothing); with `look` one at each room's
        middle too, to see all its markers from one place."""
        points: list[tuple[float, float] | None] = [None]
        for i in range(self.rooms):
            x = ROOM_M * i + 2
            points.append((x, 0.0))
            for side in (1, -1):
                if look:
                    points += [(x, side * 3.0), None]
                near, far = side * 2.0, side * 4.0
                points += [(x, near), (x - 1, near), (x - 1, far), (x + 1, far), (x + 1, near),
                           (x, near), (x, 0.0)]  # fmt: skip
        return [*points, (DOCK.x, DOCK.y)]


@dataclass
class Walk:
    """A survey through `building`: the truth, the wheels' readings and the camera's
    sightings, handed to a SurveyLog as the mission would.

    The casters turn the robot after each turn on the spot by up to 45 degrees the way
    it turned, as the simulator's (a random share of the worst, in proportion to the
    turn up to a quarter); or, `model`, by a draw from the solver's own prior. With
    `model` the start is also drawn from the dock's prior and each marker put off its
    wall by the wall's sigmas: the world then follows the solver's model exactly."""

    building: Building
    seed: int
    model: bool = False
    look: bool = True
    misread_rate: float = 0.005  # an id misread as another marker's
    no_facing_rate: float = 0.1  # the detector gives no facing
    moved: int | None = None  # a marker moved 1 m along its wall half-way through
    noise: FilterNoise = field(default_factory=FilterNoise)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.markers = self.building.markers.copy()
        self.truth = np.array([DOCK.x, DOCK.y, DOCK.heading])
        if self.model:
            self.truth += self.rng.multivariate_normal(np.zeros(3), start_covariance())
            normals = np.stack([np.cos(self.markers[:, 2]), np.sin(self.markers[:, 2])], 1)
            self.markers[:, :2] += normals * self.rng.normal(0, 0.02, (len(normals), 1))
            self.markers[:, 2] += self.rng.normal(0, math.radians(2), len(normals))
        self.log = SurveyLog(DOCK, WHEEL_BASE, noise=self.noise)
        self.caster = 0.0
        self.frames = 0
        self.misreads: set[float] = set()  # the sightings misread (their Observation.time)
        self.moved_at: int | None = None  # the frame the marker moved at
        self.before_move: np.ndarray | None = None

    def drive(self) -> Walk:
        route = self.building.route(self.look)
        for n, goal in enumerate(route):
            if self.moved is not None and self.moved_at is None and n >= len(route) // 2:
                self._move_marker(self.moved)
            if goal is None:
                self._turn(math.tau)
                continue
            x, y, heading = self.truth
            self._turn(wrap(math.atan2(goal[1] - y, goal[0] - x) - heading))
            self._drive_to(goal)
        return self

    def _move_marker(self, marker: int) -> None:
        self.before_move = self.markers[marker].copy()
        facing = self.markers[marker, 2]  # 1 m to its right, as the robot faces it
        self.markers[marker, :2] += (math.sin(facing), -math.cos(facing))
        self.moved_at = self.frames

    def _turn(self, angle: float) -> None:
        if abs(angle) < math.radians(3):
            return
        steps = max(1, round(abs(angle) / math.radians(5)))
        for _ in range(steps):
            arc = angle / steps * WHEEL_BASE / 2
            self._move(-arc, arc, in_place=True)
        share = min(1.0, abs(angle) / (math.pi / 2))
        noise = self.noise
        if self.model:
            self.caster += math.copysign(noise.caster_share * noise.caster_worst * share, angle)
            self.caster += self.rng.normal(0, noise.caster_sigma * share)
        else:
            worst = noise.caster_worst
            kick = math.copysign(worst * share * self.rng.uniform(0.3, 1.0), angle)
            self.caster = max(-worst, min(worst, self.caster + kick))

    def _drive_to(self, goal: tuple[float, float]) -> None:
        """Steering by the true pose: the survey's own steering is not under test."""
        for _ in range(2000):
            x, y, heading = self.truth
            dx, dy = goal[0] - x, goal[1] - y
            to_go = math.hypot(dx, dy)
            if to_go < 0.03:
                return
            step = min(0.05, to_go)
            turn = max(-0.15, min(0.15, wrap(math.atan2(dy, dx) - heading))) if to_go > 0.1 else 0
            self._move(step - turn * WHEEL_BASE / 2, step + turn * WHEEL_BASE / 2)

    def _move(self, left: float, right: float, in_place: bool = False) -> None:
        rng, noise = self.rng, self.noise
        read_left = left + rng.normal(0, noise.wheel_noise * math.sqrt(abs(left)))
        read_right = right + rng.normal(0, noise.wheel_noise * math.sqrt(abs(right)))
        distance = (left + right) / 2
        unseen = rng.normal(0, noise.heading_noise * math.sqrt(abs(distance)))
        turn = (right - left) / WHEEL_BASE + unseen
        if not in_place and self.caster:
            released = self.caster * -math.expm1(-abs(distance) / noise.caster_settle)
            self.caster -= released
            turn += released
        mid = self.truth[2] + turn / 2
        self.truth = self.truth + np.array([distance * math.cos(mid), distance * math.sin(mid),
                                            turn])  # fmt: skip
        self.log.wheels(read_left, read_right, turned_in_place=in_place)
        self._frame()

    def _frame(self) -> None:
        """What the camera sees from the true pose: each marker in the same room (or the
        corridor), in the field of view, read from in front, within reach."""
        self.frames += 1
        x, y, heading = self.truth
        m = self.markers
        dx, dy = m[:, 0] - x, m[:, 1] - y
        r = np.hypot(dx, dy)
        bearing = np.remainder(np.arctan2(dy, dx) - heading + math.pi, math.tau) - math.pi
        view = np.remainder(m[:, 2] - np.arctan2(-dy, -dx) + math.pi, math.tau) - math.pi
        seen = ((self.building.space == self.building.space_of(x, y)) & (r > 0.3) & (r < REACH_M)
                & (np.abs(bearing) < FIELD_OF_VIEW) & (np.abs(view) < READ_FROM))  # fmt: skip
        rng, noise = self.rng, self.noise
        sightings = []
        for j, i in enumerate(np.flatnonzero(seen)):
            time = self.frames + j / 100  # one of its own for each sighting
            marker_id = int(i)
            if rng.random() < self.misread_rate:
                marker_id = int(rng.integers(len(m)))
                self.misreads.add(time)
            facing = None
            if rng.random() >= self.no_facing_rate:
                facing = wrap(m[i, 2] - heading) + rng.normal(0, noise.facing)
            sightings.append(Observation(
                marker_id, r[i] + rng.normal(0, noise.distance + noise.distance_fraction * r[i]),
                bearing[i] + rng.normal(0, noise.bearing), facing, time))  # fmt: skip
        self.log.frame(sightings)


def position_errors(result: SurveyResult, markers: np.ndarray) -> np.ndarray:
    """Each marker's distance from where it truly is, in the result's order."""
    return np.array([math.hypot(m.pose.x - markers[i, 0], m.pose.y - markers[i, 1])
                     for i, m in result.markers.items()])  # fmt: skip


def chi_square_mean_band(dof: int, samples: int, confidence: float = 0.99) -> tuple[float, float]:
    """Bounds on the mean of `samples` chi-square(dof) values (Wilson-Hilferty)."""
    k = dof * samples
    z = NormalDist().inv_cdf(0.5 + confidence / 2)

    def quantile(zp: float) -> float:
        return k * (1 - 2 / (9 * k) + zp * math.sqrt(2 / (9 * k))) ** 3

    return quantile(-z) / samples, quantile(z) / samples


@cache
def six_rooms() -> tuple[Walk, Survey]:
    """A six-room survey, casters as the simulator's, a few misreads, and one corridor
    marker moved along its wall half-way through (it is seen going out and coming back)."""
    walk = Walk(Building(3), seed=1, moved=10).drive()
    return walk, walk.log.survey()


@cache
def six_rooms_on_walls() -> SurveyResult:
    walk, survey = six_rooms()
    return solve_on_walls(survey, walk.building.plan)


# The log.


def test_the_log_integrates_the_wheels_as_the_filter_does() -> None:
    log = SurveyLog(DOCK, WHEEL_BASE)
    f = PoseFilter(DOCK, np.zeros((3, 3)))
    steps = [(0.05, 0.05)] * 6 + [(0.04, 0.06)] * 6 + [(0.06, 0.05)] * 4  # under a metre: one edge
    for left, right in steps:
        log.wheels(left, right)
        f.predict(left, right, WHEEL_BASE)
    (edge,) = log.survey().odometry
    moved = f.pose
    assert (edge.motion.x, edge.motion.y) == pytest.approx((moved.x - DOCK.x, moved.y - DOCK.y))
    assert edge.motion.heading == pytest.approx(moved.heading)
    floor = np.diag([0.001**2, 0.001**2, math.radians(0.05) ** 2])
    assert edge.covariance == pytest.approx(f.covariance + floor, rel=1e-9, abs=1e-15)


def test_a_contact_widens_the_edge_under_way_as_it_widens_the_filter() -> None:
    """A contact during a survey (Localisation.touched) reaches the log: the robot may
    have pivoted on what it clipped, so the edge it is on allows for it."""
    odometry = Odometry()
    localisation = Localisation(odometry)
    log = SurveyLog(DOCK, odometry.wheel_base)
    localisation.start_survey(log)
    log.wheels(0.3, 0.3)
    before = log.survey().odometry[-1].covariance
    localisation.touched()
    after = log.survey().odometry[-1].covariance
    assert after[2, 2] - before[2, 2] == pytest.approx(CONTACT_SIGMA_HEADING**2)
    assert after[0, 0] - before[0, 0] == pytest.approx(CONTACT_SIGMA_M**2)


def test_a_turn_on_the_spot_makes_a_casters_turn_with_the_filters_prior() -> None:
    log = SurveyLog(DOCK, WHEEL_BASE)
    arc = math.pi / 2 * WHEEL_BASE / 2 / 18
    for _ in range(18):
        log.wheels(-arc, arc, turned_in_place=True)
    before = log.keyframes
    for _ in range(10):
        log.wheels(0.05, 0.05)
    noise = FilterNoise()
    (turn,) = log.survey().caster_turns
    assert turn.expected == pytest.approx(noise.caster_share * noise.caster_worst)
    assert turn.sigma == pytest.approx(noise.caster_sigma)
    # A keyframe where it set off: the edge after releases the casters' turn, as
    # PoseFilter.predict releases it, 1 - exp(-d / 0.3 m) of it over d.
    assert log.keyframes == before + 1
    edge = log.survey().odometry[-1]
    assert edge.caster == 0
    assert edge.release == pytest.approx(-math.expm1(-0.5 / noise.caster_settle))
    assert 0 < edge.sway < edge.release


def test_turns_on_the_spot_in_a_row_expect_the_casters_turn_no_further_than_their_worst() -> None:
    """Three quarter turns, each set off from by a centimetre: each casters' turn carries
    nearly all of the last, and unclamped their means would add up to 65 degrees. The
    filter holds the turn to come at the casters' worst (45); so does the graph, and
    with nothing else to go by its solution is those means."""
    log = SurveyLog(DOCK, WHEEL_BASE)
    arc = math.pi / 2 * WHEEL_BASE / 2 / 18
    for _ in range(3):
        for _ in range(18):
            log.wheels(-arc, arc, turned_in_place=True)
        log.wheels(0.01, 0.01)
    for _ in range(10):
        log.wheels(0.05, 0.05)
    survey = log.survey()
    noise = FilterNoise()
    first, *rest = survey.caster_turns
    assert all(turn.carried > 0.9 for turn in rest)
    unclamped = first.expected * (1 + sum(np.cumprod([t.carried for t in rest])))
    assert unclamped > math.radians(60)
    turns = solve_survey(survey).caster_turns
    assert max(turns) == pytest.approx(noise.caster_worst, abs=1e-6)
    assert all(turn <= noise.caster_worst + 1e-9 for turn in turns)
    assert turns[0] == pytest.approx(first.expected, abs=1e-6)


def test_the_log_keeps_one_sighting_per_marker_per_keyframe() -> None:
    walk, survey = six_rooms()
    pairs = [(s.keyframe, s.seen.marker_id) for s in survey.sightings]
    assert len(pairs) == len(set(pairs))
    # Keyframes at about a quarter metre while driving (frames every 5 cm here), and
    # fewer sightings kept than the camera made.
    travel = [math.hypot(e.motion.x, e.motion.y) for e in survey.odometry]
    driving = [t for t in travel if t > 0.1]
    assert np.median(driving) == pytest.approx(KEYFRAME_TRAVEL_M, abs=0.05)
    assert len(survey.sightings) < walk.frames


# The model.


def test_the_sightings_model_is_the_filters() -> None:
    """A robot known exactly sees a marker known only roughly: the survey puts the marker
    where PoseFilter.expected's model says a marker seen so must be."""
    robot, marker = Pose(1.0, 2.0, 0.3), Pose(3.5, 2.5, -2.9)
    expected = PoseFilter().expected(marker, robot)
    rough = PosePrior(Pose(3.0, 3.0, -2.5), 100 * np.eye(3))
    survey = Survey(PosePrior(robot, np.diag([1e-8, 1e-8, 1e-10])), known={7: rough},
                    sightings=[Sighting(0, replace(expected, marker_id=7))])  # fmt: skip
    m = solve_survey(survey).markers[7].pose
    assert (m.x, m.y) == pytest.approx((marker.x, marker.y), abs=0.002)
    assert wrap(m.heading - marker.heading) == pytest.approx(0.0, abs=0.002)


def test_the_jacobian_is_the_residuals_derivative() -> None:
    walk = Walk(Building(1), seed=3, look=False).drive()
    survey = walk.log.survey(walls=dict(enumerate(walk.building.walls)))
    # The graph as solve_survey builds it (the module's own helpers: the model is what
    # is under test here).
    graph, sightings = pose_graph._graph(survey)
    x = pose_graph._start(survey, graph, sightings, None)
    x += np.random.default_rng(0).normal(0, 0.05, x.size)
    # Every casters' turn's column, and a sample of the others.
    sample = np.random.default_rng(1).choice(x.size, 120, replace=False)
    columns = np.concatenate([np.arange(3 * graph.keyframes, graph.pose_size), sample])
    analytic = graph.jacobian(x).toarray()[:, columns]
    numeric = np.empty_like(analytic)
    r0, eps = graph.residuals(x), 1e-7
    for n, i in enumerate(columns):
        moved = x.copy()
        moved[i] += eps
        numeric[:, n] = (graph.residuals(moved) - r0) / eps
    assert np.abs(numeric).max() > 1.0
    assert analytic == pytest.approx(numeric, abs=2e-4 * np.abs(numeric).max())


# A survey: accuracy, outliers, honest covariances.


def test_with_the_plans_walls_the_markers_are_within_5_cm_at_p95() -> None:
    walk, survey = six_rooms()
    on_walls = six_rooms_on_walls()
    truth = walk.markers.copy()
    truth[walk.moved] = walk.before_move  # the moved marker is judged elsewhere
    errors = position_errors(on_walls, truth)
    errors = errors[[i != walk.moved for i in on_walls.markers]]
    assert on_walls.converged
    assert np.percentile(errors, 95) <= 0.05
    # Every marker found its own wall, none another's.
    held = {i: m.wall for i, m in on_walls.markers.items() if m.wall is not None}
    assert len(held) >= 0.9 * len(on_walls.markers)
    for i, wall in held.items():
        assert math.isfinite(wall.sigma_m)
        along = np.subtract(wall.b, wall.a) / math.dist(wall.a, wall.b)
        off = np.subtract(walk.markers[i, :2], wall.a)
        assert abs(along[0] * off[1] - along[1] * off[0]) < 1e-9
    # Without walls the dock's 3 degrees and the heading's drift room by room leave it
    # decimetres out: the figure the report gives.
    alone = position_errors(solve_survey(survey), truth)
    assert np.percentile(alone, 95) > 2 * np.percentile(errors, 95)


def test_misread_markers_and_a_moved_one_are_left_out() -> None:
    walk, _ = six_rooms()
    result = six_rooms_on_walls()
    flagged = {o.sighting.seen.time for o in result.outliers if not o.facing_only}
    misread = {s.seen.time for s in walk.log.sightings if s.seen.time in walk.misreads}
    assert len(misread) >= 5
    assert len(misread & flagged) >= 0.9 * len(misread)
    # The moved marker: its sightings from one side of the move are left out, and it is
    # where the others saw it.
    assert walk.moved is not None and walk.moved_at is not None and walk.before_move is not None
    moved = [o for o in result.outliers if o.sighting.seen.marker_id == walk.moved]
    assert len(moved) >= 3
    sides = {o.sighting.seen.time > walk.moved_at for o in moved}
    assert len(sides) == 1
    kept_at = walk.before_move if sides == {True} else walk.markers[walk.moved]
    at = result.markers[walk.moved].pose
    assert math.hypot(at.x - kept_at[0], at.y - kept_at[1]) < 0.1
    # Few good sightings lost.
    good = len(walk.log.sightings) - len(misread)
    assert len(flagged - misread) - len(moved) <= 0.01 * good
    for o in result.outliers:
        assert o.mahalanobis > CHI_SQUARE[0.999][1 if o.facing_only else 2]


@cache
def consistent_walks() -> list[tuple[Walk, SurveyResult, SurveyResult]]:
    """Surveys whose world follows the solver's model (Walk.model), solved without and
    with each marker's wall (the walls given, as beliefs)."""
    out = []
    for seed in range(6):
        walk = Walk(Building(1), seed=100 + seed, model=True, look=False, misread_rate=0.0).drive()
        survey = walk.log.survey()
        walls = dict(enumerate(walk.building.walls))
        out.append((walk, solve_survey(survey), solve_survey(replace(survey, walls=walls))))
    return out


def marker_errors(result: SurveyResult, markers: np.ndarray) -> np.ndarray:
    """Each marker's error (x, y, facing), in the result's order."""
    return np.array([(m.pose.x - markers[i, 0], m.pose.y - markers[i, 1],
                      wrap(m.pose.heading - markers[i, 2]))
                     for i, m in result.markers.items()])  # fmt: skip


def test_on_walls_the_covariances_are_honest() -> None:
    """Where the world follows the model, every marker's error, all of a survey's
    markers together, against their joint covariance: the normalised estimation error
    squared is chi-square with three degrees of freedom a marker, summed over the
    surveys (each survey's path and dock independent of the others')."""
    total, dof = 0.0, 0
    for walk, _, on_walls in consistent_walks():
        e = marker_errors(on_walls, walk.markers).ravel()
        total += float(e @ np.linalg.solve(on_walls.joint_covariance, e))
        dof += len(e)
    low, high = chi_square_mean_band(1, dof)
    assert low < total / dof < high
    # Each marker's covariance is its block of the joint one.
    first = next(iter(on_walls.markers.values()))
    assert first.covariance == pytest.approx(on_walls.joint_covariance[:3, :3])


def test_the_last_keyframe_is_where_the_walk_ends_as_surely_as_it_says() -> None:
    """Where the world follows the model, the last keyframe (where a survey redraws the
    robot mid-way, missions/survey.py) is off the walk's true end as its covariance
    says: chi-square with three degrees of freedom a survey."""
    total, dof = 0.0, 0
    for walk, _, on_walls in consistent_walks():
        end, truth = on_walls.keyframes[-1], walk.truth
        e = np.array([end.x - truth[0], end.y - truth[1], wrap(end.heading - truth[2])])
        total += float(e @ np.linalg.solve(on_walls.last_covariance, e))
        dof += 3
    low, high = chi_square_mean_band(1, dof)
    assert low < total / dof < high


def test_without_walls_each_markers_covariance_is_honest() -> None:
    """Without walls the map's heading is held only by the dock's 3 degrees and the
    casters' 20-degree priors where nothing measures them, and over metres of lever
    the errors bend further than a linearisation says: the joint covariance is a little
    too sure (a normalised error of 1.2 to 1.6 a degree of freedom on these surveys). Each
    marker's own is honest: its normalised error squared, averaged per survey, and over
    the surveys, is 3 within a chi-square band. A survey's markers share its path's
    error, so its average spreads at most as one chi-square(3) draw: the band for one
    draw per survey is conservative."""
    averages = []
    for walk, alone, _ in consistent_walks():
        errors = marker_errors(alone, walk.markers)
        covariances = [m.covariance for m in alone.markers.values()]
        averages.append(np.mean([e @ np.linalg.solve(c, e)
                                 for e, c in zip(errors, covariances, strict=True)]))  # fmt: skip
    low, high = chi_square_mean_band(3, len(averages))
    assert low < np.mean(averages) < high


# Covariances of single markers, and what the online filter gets.


def straight_survey(steps: int, step_m: float = 0.3,
                    dock: np.ndarray | None = None) -> tuple[Survey, list[Pose]]:  # fmt: skip
    """A robot driving along +x from the dock (known to `dock`, localisation's start
    covariance by default), its wheels read exactly."""
    log = SurveyLog(DOCK, WHEEL_BASE, start_cov=dock)
    poses = [DOCK]
    for _ in range(steps):
        for _ in range(5):
            log.wheels(step_m / 5, step_m / 5)
        log.frame([Observation(-1, 10.0, 0.0, 0.0)])  # cuts a keyframe
        poses.append(Pose(poses[-1].x + step_m, 0.0, 0.0))
    survey = log.survey()
    return replace(survey, sightings=[]), poses


def test_a_marker_seen_once_from_far_is_known_loosely() -> None:
    # The dock known to a millimetre: the markers' own geometry is under test.
    survey, poses = straight_survey(12, dock=np.diag([1e-6, 1e-6, 1e-8]))
    near, far = Pose(2.0, 1.0, -math.pi / 2), Pose(4.0, 4.5, -math.pi / 2)
    filter_ = PoseFilter()
    sightings = [Sighting(k, replace(filter_.expected(near, poses[k]), marker_id=1))
                 for k in range(4, 9)]  # fmt: skip
    sightings.append(Sighting(2, replace(filter_.expected(far, poses[2]), marker_id=2)))
    result = solve_survey(replace(survey, sightings=sightings))
    seen_near, seen_far = result.markers[1], result.markers[2]
    assert seen_far.sigma_m > 3 * seen_near.sigma_m
    # At least what that one sighting's noise gives, from a robot known exactly.
    alone = marker_from_sighting(poses[2], np.zeros((3, 3)), sightings[-1].seen)
    assert seen_far.sigma_m >= math.sqrt(np.linalg.eigvalsh(alone.covariance[:2, :2])[-1])
    assert seen_far.sigma_m > 0.1


def test_a_marker_from_one_sighting_inverts_the_measurement_model() -> None:
    robot, marker = Pose(1.0, -2.0, 2.0), Pose(-1.5, -0.5, -0.4)
    seen = replace(PoseFilter().expected(marker, robot), marker_id=4)
    guess = marker_from_sighting(robot, start_covariance(), seen)
    assert (guess.pose.x, guess.pose.y) == pytest.approx((marker.x, marker.y))
    assert wrap(guess.pose.heading - marker.heading) == pytest.approx(0.0, abs=1e-12)
    # Its covariance is what noisy sightings from robots drawn about `robot` give, and it
    # is tied to the robot's.
    rng = np.random.default_rng(5)
    noise = FilterNoise()
    assert seen.facing_rad is not None
    draws = []
    for _ in range(2000):
        at = rng.multivariate_normal([robot.x, robot.y, robot.heading], start_covariance())
        r = seen.distance_m
        noisy = Observation(4, r + rng.normal(0, noise.distance + noise.distance_fraction * r),
                            seen.bearing_rad + rng.normal(0, noise.bearing),
                            seen.facing_rad + rng.normal(0, noise.facing))  # fmt: skip
        p = marker_from_sighting(Pose(*at), np.zeros((3, 3)), noisy).pose
        draws.append((p.x, p.y, wrap(p.heading - marker.heading)))
    spread = np.cov(np.array(draws).T)
    assert np.sqrt(np.diag(spread)) == pytest.approx(np.sqrt(np.diag(guess.covariance)), rel=0.08)
    assert guess.with_robot.shape == (3, 3) and guess.with_robot[0, 0] > 0


def test_a_marker_seen_without_its_facing_faces_the_robot_loosely() -> None:
    robot = Pose(0.0, 0.0, 0.0)
    guess = marker_from_sighting(robot, np.zeros((3, 3)), Observation(3, 2.0, 0.2, None))
    assert not guess.facing_seen
    assert wrap(guess.pose.heading - (0.2 + math.pi)) == pytest.approx(0.0, abs=1e-12)
    assert math.degrees(math.sqrt(guess.covariance[2, 2])) == pytest.approx(45.0, rel=0.01)


# Walls found from the plan.


def test_a_marker_gets_its_wall_when_only_one_line_can_be_it() -> None:
    marker = Pose(1.0, 1.01, -math.pi / 2)
    walls = [Wall((0.0, 1.0), (1.55, 1.0)), Wall((0.0, 1.0), (4.0, 1.0)),  # one line, twice
             Wall((0.0, 5.0), (4.0, 5.0)), Wall((0.0, 1.0), (0.0, 5.0))]  # fmt: skip
    sure = SurveyedMarker(1, marker, np.diag([0.05**2, 0.05**2, math.radians(3) ** 2]), 10, True)
    assert assign_walls({1: sure}, walls)[1] == walls[0]
    # Known to metres: either corridor-facing line might be its own, both face the same
    # way, so only the facing is held.
    loose = replace(sure, covariance=np.diag([3.0**2, 3.0**2, math.radians(3) ** 2]))
    held = assign_walls({1: loose}, walls)[1]
    assert math.isinf(held.sigma_m)
    # Facing no wall of the plan: none.
    askew = replace(sure, pose=Pose(1.0, 1.01, -math.pi / 2 + math.radians(30)))
    assert assign_walls({1: askew}, walls) == {}


def test_a_marker_on_a_grids_wall_is_held_to_the_face_it_faces_out_of() -> None:
    # A grid's wall 0.1 m thick: its two faces, each seen from one side only. A marker
    # on the lower face, facing down, known to 5 cm: both lines pass its gate, but the
    # upper face looks the other way, so the lower one is its own (not held by its
    # facing only, which left an imported clinic's markers at 21 cm).
    marker = Pose(1.0, 0.99, -math.pi / 2)
    lower = Wall((0.0, 1.0), (4.0, 1.0), facing=-math.pi / 2)
    upper = Wall((0.0, 1.1), (4.0, 1.1), facing=math.pi / 2)
    loose = SurveyedMarker(1, marker, np.diag([0.05**2, 0.05**2, math.radians(3) ** 2]), 10, True)
    assert assign_walls({1: loose}, [lower, upper])[1] == lower
    # Seen either way (an outline's edge), the two lines leave only the facing held.
    either = [replace(lower, facing=None), replace(upper, facing=None)]
    assert math.isinf(assign_walls({1: loose}, either)[1].sigma_m)


def test_a_misread_from_beyond_its_wall_does_not_turn_a_marker_round() -> None:
    """A marker on an end wall, seen from in front, and its id misread once from far
    beyond the wall: the marker still faces the way it was seen from, and its wall
    holds (its side is the side most of its sightings came from)."""
    survey, poses = straight_survey(100)
    marker = Pose(4.0, 0.3, math.pi)
    sightings = [Sighting(k, replace(PoseFilter().expected(marker, poses[k]), marker_id=7))
                 for k in range(2, 10)]  # fmt: skip
    misread = Sighting(98, Observation(7, 2.0, 0.1, 0.0))
    wall = Wall((4.0, -1.0), (4.0, 1.0))
    result = solve_survey(replace(survey, sightings=[*sightings, misread], walls={7: wall}))
    m = result.markers[7]
    assert [o.sighting for o in result.outliers] == [misread]
    assert m.wall == wall and not m.wall_rejected
    assert wrap(m.pose.heading - math.pi) == pytest.approx(0.0, abs=math.radians(1))


def test_a_misread_facing_is_left_out_alone_and_where_it_was_seen_kept() -> None:
    """Read from far off or askew, a small marker's facing can come out flipped while its
    distance and bearing are right: only the facing is left out, and the sighting
    still places the marker (a survey's graph once lost the one tie between a dead-end
    room's new markers and the corridor that way)."""
    survey, poses = straight_survey(100)
    marker = Pose(4.0, 0.3, math.pi)
    sightings = [Sighting(k, replace(PoseFilter().expected(marker, poses[k]), marker_id=7))
                 for k in range(2, 10)]  # fmt: skip
    seen = sightings[-1].seen
    assert seen.facing_rad is not None
    flipped = Sighting(10, replace(PoseFilter().expected(marker, poses[10]), marker_id=7,
                                   facing_rad=wrap(seen.facing_rad + 2.2)))  # fmt: skip
    result = solve_survey(replace(survey, sightings=[*sightings, flipped]))
    (left_out,) = result.outliers
    assert left_out.sighting == flipped and left_out.facing_only
    assert left_out.mahalanobis > CHI_SQUARE[0.999][1]
    m = result.markers[7]
    assert m.sightings == len(sightings) + 1 and m.facing_seen
    assert wrap(m.pose.heading - math.pi) == pytest.approx(0.0, abs=math.radians(1))


def test_a_marker_whose_every_facing_is_beyond_the_bound_keeps_them() -> None:
    """At a solution that turns a marker 60 degrees from all its facings, they are all
    there is of its facing: none is left out, whether or not the marker was also seen
    once without one (which must not count as a facing that agrees)."""
    survey, poses = straight_survey(12, dock=np.diag([1e-6, 1e-6, 1e-8]))
    marker = Pose(2.0, 1.5, -math.pi / 2)
    faced = [Sighting(k, replace(PoseFilter().expected(marker, poses[k]), marker_id=1))
             for k in range(3, 9)]  # fmt: skip
    unfaced = Sighting(10, replace(PoseFilter().expected(marker, poses[10]), marker_id=1,
                                   facing_rad=None))  # fmt: skip
    for sightings in (faced, [*faced, unfaced]):
        with_them = replace(survey, sightings=sightings)
        graph, kept = pose_graph._graph(with_them)
        x = pose_graph._start(with_them, graph, kept, None)
        graph.split(x)[2][0, 2] += math.radians(60)
        rejected = outliers(graph, x)
        assert rejected.facings == frozenset() and rejected.sightings == frozenset()


# What does not hang together, and what there is too little of.


def test_no_sightings_gives_the_wheels_path_and_no_markers() -> None:
    survey, poses = straight_survey(6)
    result = solve_survey(survey)
    assert result.markers == {} and result.outliers == () and result.converged
    path = np.array([(p.x, p.y, p.heading) for p in result.keyframes])
    assert path == pytest.approx(np.array([(p.x, p.y, p.heading) for p in poses]), abs=1e-9)


def test_a_marker_seen_only_without_its_facing_is_placed_and_says_so() -> None:
    survey, poses = straight_survey(8)
    marker = Pose(1.5, 1.5, -math.pi / 2)
    sightings = [Sighting(k, replace(PoseFilter().expected(marker, poses[k]), marker_id=5,
                                     facing_rad=None)) for k in range(2, 7)]  # fmt: skip
    m = solve_survey(replace(survey, sightings=sightings)).markers[5]
    assert not m.facing_seen
    assert (m.pose.x, m.pose.y) == pytest.approx((marker.x, marker.y), abs=0.02)
    assert m.sigma_facing == pytest.approx(math.radians(45), rel=0.01)


def test_a_known_marker_places_the_path_the_dock_cannot() -> None:
    """The dock known only to a metre and 20 degrees; a marker on the way known to a
    centimetre: the path, and a new marker seen from it, are placed by the known one."""
    survey, poses = straight_survey(10, dock=np.diag([1.0, 1.0, math.radians(20) ** 2]))
    known, new = Pose(1.5, 1.0, -math.pi / 2), Pose(3.0, -1.0, math.pi / 2)
    expected = PoseFilter().expected
    sightings = [Sighting(k, replace(expected(marker, poses[k]), marker_id=i))
                 for k in range(1, 10) for i, marker in ((1, known), (2, new))
                 if abs(expected(marker, poses[k]).bearing_rad) < math.radians(80)]  # fmt: skip
    prior = PosePrior(known, np.diag([1e-4, 1e-4, math.radians(0.5) ** 2]))
    result = solve_survey(replace(survey, sightings=sightings, known={1: prior}))
    path = np.array([(p.x, p.y) for p in result.keyframes])
    assert path == pytest.approx(np.array([(p.x, p.y) for p in poses]), abs=0.01)
    m = result.markers[2]
    assert (m.pose.x, m.pose.y) == pytest.approx((new.x, new.y), abs=0.01)
    # Without it, the new marker is known only as well as the dock.
    alone = solve_survey(replace(survey, sightings=[s for s in sightings if s.seen.marker_id == 2]))
    assert alone.markers[2].sigma_m > 1.0 > 5 * m.sigma_m


def test_priors_for_markers_never_seen_are_kept_or_named() -> None:
    survey, poses = straight_survey(4)
    on_wall = Pose(1.0, 1.0, -math.pi / 2)
    seen = Sighting(2, replace(PoseFilter().expected(on_wall, poses[2]), marker_id=1))
    known = PosePrior(Pose(9.0, 9.0, 1.0), np.diag([0.01, 0.01, 0.001]))
    result = solve_survey(replace(survey, sightings=[seen], known={8: known},
                                  walls={1: Wall((0.0, 1.0), (3.0, 1.0)),
                                         42: Wall((0.0, -1.0), (3.0, -1.0))}))  # fmt: skip
    assert result.unseen == (42,)
    assert result.markers[8].pose == known.pose and result.markers[8].sightings == 0
    assert result.markers[8].covariance == pytest.approx(known.covariance)
    assert result.markers[1].wall is not None


def bad_surveys() -> Iterator[tuple[str, Survey]]:
    survey, _ = straight_survey(3)
    good = Sighting(1, Observation(1, 2.0, 0.1, 0.2))
    yield "no keyframe 9", replace(survey, sightings=[replace(good, keyframe=9)])
    yield "positive distance", replace(survey, sightings=[replace(good, seen=Observation(
        1, 0.0, 0.1, 0.2))])  # fmt: skip
    yield "not positive definite", replace(survey, start=PosePrior(DOCK, np.zeros((3, 3))))
    yield "no casters' turn 3", replace(survey, odometry=[replace(survey.odometry[0], caster=3),
                                                          *survey.odometry[1:]])  # fmt: skip
    yield "sigma must be positive", replace(survey, caster_turns=[CasterTurn(0.1, 0.0)])
    yield "no length", replace(survey, sightings=[good], walls={1: Wall((1.0, 1.0), (1.0, 1.0))})
    yield (
        "not symmetric",
        replace(
            survey,
            odometry=[
                OdometryEdge(
                    Pose(0.25, 0.0, 0.0), np.array([[1e-4, 1e-5, 0], [0, 1e-4, 0], [0, 0, 1e-4]])
                )
            ]
            * 3,
        ),
    )


@pytest.mark.parametrize(("message", "survey"), list(bad_surveys()),
                         ids=[message for message, _ in bad_surveys()])  # fmt: skip
def test_a_survey_that_does_not_hang_together_is_a_value_error(message: str,
                                                              survey: Survey) -> None:  # fmt: skip
    with pytest.raises(ValueError, match=message):
        solve_survey(survey)


def test_a_start_from_another_survey_is_a_value_error() -> None:
    short, _ = straight_survey(3)
    longer, _ = straight_survey(5)
    with pytest.raises(ValueError, match="not a solution of this survey"):
        solve_survey(longer, start=solve_survey(short))


def test_whiteners_whiten() -> None:
    c = np.array([[[4e-4, 1e-4, 0.0], [1e-4, 2e-4, 1e-5], [0.0, 1e-5, 1e-3]]])
    w = whiteners(c, "edge")[0]
    assert w.T @ w == pytest.approx(np.linalg.inv(c[0]))
