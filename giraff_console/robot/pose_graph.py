"""The robot maps its own markers (§2.3.4, issue 25): every marker's pose, estimated jointly
with the robot's path through a survey, and how well each is known.

Pure: no I/O, no clock, no threads. The survey mission drives (or follows the operator)
through the building, and hands `solve_survey` what it logged (survey_log.py makes it
from the wheels and the camera's frames): keyframes along the way, the wheels' motion
between them, the markers seen from each; and what is known already (the dock it started
on, markers already mapped, walls markers are believed to hang on: survey_walls.py finds
those from the plan's walls).

Why a pose graph solved in one go, not the EKF grown into EKF-SLAM
    The thesis (§2.3.4) names the trouble with EKF-SLAM: every marker is tied to every
    other through the robot's path, so one covariance over all of them is updated at
    every sighting, and each early linearisation is kept for good. A survey's map is
    wanted at its end: Gauss-Newton on the whole path relinearises every keyframe where
    it ends up, and the path makes the problem sparse (a keyframe is tied to its
    neighbours and the markers it saw). pose_graph_solve.py says how it is solved,
    pose_graph_start.py where from, pose_graph_model.py the residuals. The online filter
    keeps its EKF: `marker_from_sighting` gives it a new marker's pose.

The model, and why
    - Sightings: ekf.py's measurement model (distance and bearing from the camera, and
      the marker's facing when the detector gives it) with its camera noise (2 cm + 2 %
      of the distance, 1 degree, 6 degrees), each sighting's errors independent of the
      next's. Not its marker placement terms (1 cm, 1 degree): those are the plan's
      error in where a marker hangs, and here where it hangs is the unknown.
    - Wheels: each edge's motion and covariance from the EKF's own noise model,
      integrated step by step as PoseFilter.predict does (survey_log.py).
    - The casters (§3.2.1.5): after a turn on the spot they turn the robot, unseen by
      the wheels, by up to about 45 degrees the way it turned, over the next metre. The
      EKF holds the turn still to come in its state; here each turn on the spot has an
      unknown of its own, the whole turn its casters will make, with the EKF's prior
      (half the worst, give or take 20 degrees, with what was left of the last), and the
      edges after it release it into the heading as the EKF does (1 - exp(-d / 0.3 m)).
      Not extra heading variance on those edges: the turn is one unknown shared by the
      four or five edges after it, all the same way; as independent noise on each it
      would be too sure of the sum or too loose on each edge, and would throw away which
      way it turns. As an unknown it costs one column per turn, and the markers seen
      over that metre measure it.
    - Walls: a marker believed to hang on a wall of the plan is held to the wall's line
      (2 cm) and to face square out of it (2 degrees), on the side it was seen from. The
      plan's walls are real knowledge, and what keeps a marker far from the dock within
      centimetres: the path's heading error grows room by room, a wall's direction
      does not. A marker on no wall is estimated all the same.
    - Outliers: a misread marker, or one moved mid-survey, sits far from the rest of its
      sightings. Sightings, walls and known markers get Cauchy's loss (robust beyond
      three sigma); the wheels and the dock do not (they are never wrong that way, and
      down-weighting an edge would break the chain). What then lies beyond the
      chi-square bound at 99.9 % is an outlier, reported with its residual and left out
      of a last plain least-squares solve, whose normal matrix gives honest covariances
      (Cauchy's weights would shrink what good sightings are worth).
    - A facing nothing observes (a marker seen only without it, on no wall, not known)
      is held weakly (45 degrees) to the way the marker was seen from: it was read from
      in front.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from giraff_console.robot.ekf import FilterNoise, Observation, wrap
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph_model import (
    UNSEEN_FACING_SIGMA,
    CasterData,
    EdgeData,
    Graph,
    WallData,
    camera_sigmas,
    prepared,
    whiteners,
)
from giraff_console.robot.pose_graph_solve import (
    FINAL_ITERATIONS,
    ROBUST_ITERATIONS,
    Rejected,
    activity,
    covariances,
    gauss_newton,
    outliers,
)
from giraff_console.robot.pose_graph_start import starting_point

# A marker on a wall: its centre on the wall's line within a few centimetres (a plan's
# outline is drawn to about that, and a marker is a few millimetres proud of it), its
# facing square to the wall within a few degrees (landmarks.py's FACING_TOLERANCE_DEG).
WALL_SIGMA_M = 0.02
WALL_SIGMA_FACING = math.radians(2.0)


@dataclass(frozen=True)
class PosePrior:
    """A pose known to a covariance: the dock the survey starts on (5 cm, 3 degrees:
    localisation.start_covariance), or a marker already mapped."""

    pose: Pose
    covariance: np.ndarray  # 3x3 of (x, y, heading or facing)


@dataclass(frozen=True)
class Wall:
    """A stretch of wall from the floor plan (planning/walls.py's WallSegment's ends) a
    marker is believed to hang on, facing out of the side it was seen from. An infinite
    sigma_m holds only the marker's facing to the wall's."""

    a: tuple[float, float]
    b: tuple[float, float]
    sigma_m: float = WALL_SIGMA_M
    sigma_facing: float = WALL_SIGMA_FACING
    # Radians: the side a marker on it faces out of, where the plan knows it (a grid's
    # face); None: either side.
    facing: float | None = None


@dataclass(frozen=True)
class OdometryEdge:
    """The wheels from one keyframe to the next: the next one's pose in this one's frame
    as the wheels alone say (no casters), its covariance from the wheels' noise, and
    what the casters did meanwhile: `release` of casters' turn `caster` came out into
    the heading, and the travel was turned by `sway` of it (the share they had turned
    the robot by, on average along the way)."""

    motion: Pose
    covariance: np.ndarray
    caster: int | None = None
    release: float = 0.0
    sway: float = 0.0


@dataclass(frozen=True)
class CasterTurn:
    """A turn on the spot's casters: the whole turn they will make the robot take (an
    unknown), expected to be `expected` radians (positive left) give or take `sigma`,
    plus `carried` of the previous casters' turn, which had still that much to come."""

    expected: float
    sigma: float
    carried: float = 0.0


@dataclass(frozen=True)
class Sighting:
    """A marker seen from a keyframe (its index): one sighting per marker per keyframe."""

    keyframe: int
    seen: Observation


@dataclass(frozen=True)
class Survey:
    """What a survey logged, and what is known already. There is one keyframe more than
    edges: `odometry[k]` goes from keyframe k to k + 1, keyframe 0 is on the dock."""

    start: PosePrior
    odometry: Sequence[OdometryEdge] = ()
    sightings: Sequence[Sighting] = ()
    caster_turns: Sequence[CasterTurn] = ()
    known: Mapping[int, PosePrior] = field(default_factory=dict)
    walls: Mapping[int, Wall] = field(default_factory=dict)
    noise: FilterNoise = field(default_factory=FilterNoise)
    camera_forward: float = 0.0


@dataclass(frozen=True)
class SurveyedMarker:
    """A marker as the survey found it: its pose (centre, and its normal's facing) and
    that pose's 3x3 marginal covariance; the sightings used; whether any sighting, wall
    or known pose said its facing (else it faces the way it was seen from, to 45
    degrees); the wall it was held to, and whether a wall given was left out because the
    sightings put the marker off it."""

    marker_id: int
    pose: Pose
    covariance: np.ndarray
    sightings: int
    facing_seen: bool
    wall: Wall | None = None
    wall_rejected: bool = False

    @property
    def sigma_m(self) -> float:
        """The position's standard deviation along its worst direction."""
        return float(math.sqrt(max(0.0, np.linalg.eigvalsh(self.covariance[:2, :2])[-1])))

    @property
    def sigma_facing(self) -> float:
        return float(math.sqrt(max(0.0, self.covariance[2, 2])))


@dataclass(frozen=True)
class Outlier:
    """A sighting left out, or only its facing (`facing_only`: where it was agreed, its
    facing was misread): the squared Mahalanobis distance from what the solution
    expects of what was left out, and the sighting's error, seen less expected (metres,
    radians, radians or None)."""

    sighting: Sighting
    mahalanobis: float
    error: tuple[float, float, float | None]
    facing_only: bool = False


@dataclass(frozen=True)
class SurveyResult:
    """Every marker seen or known (by id, ascending), the keyframes where the solution
    puts them and how well the last is known (where the survey has left the robot), the
    sightings left out, each casters' turn (radians), the markers given a wall but never
    seen, and how the solve went (Gauss-Newton steps; whether it converged).
    `joint_covariance` is all the markers' poses' (3 rows and columns each, in
    `markers`' order): how well two are known relative to each other, which is better
    than either alone, as they share the path's error."""

    markers: Mapping[int, SurveyedMarker]
    keyframes: tuple[Pose, ...]
    last_covariance: np.ndarray
    outliers: tuple[Outlier, ...]
    caster_turns: tuple[float, ...]
    unseen: tuple[int, ...]
    iterations: int
    converged: bool
    joint_covariance: np.ndarray


@dataclass(frozen=True)
class MarkerGuess:
    """A marker's pose from one sighting at an uncertain robot pose: its covariance,
    and its cross-covariance with the robot's pose (rows the marker's, columns the
    robot's), which a filter adding the marker to its state needs to keep."""

    pose: Pose
    covariance: np.ndarray
    with_robot: np.ndarray
    facing_seen: bool


def marker_from_sighting(robot: Pose, covariance: np.ndarray, seen: Observation,
                         noise: FilterNoise | None = None,
                         camera_forward: float = 0.0) -> MarkerGuess:  # fmt: skip
    """Where one sighting from `robot` (known to `covariance`) puts the marker: the
    measurement model's inverse, the robot's covariance and the camera's noise carried
    through its Jacobians. Without the facing, the marker faces the robot, give or take
    45 degrees (it was read from in front). ValueError for a sighting with no distance
    or bearing."""
    seen = prepared(seen, f"marker {seen.marker_id}")
    noise = noise or FilterNoise()
    r, heading = seen.distance_m, robot.heading
    towards = heading + seen.bearing_rad
    cos_t, sin_t = math.cos(towards), math.sin(towards)
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    facing = wrap(towards + math.pi) if seen.facing_rad is None else wrap(heading + seen.facing_rad)
    pose = Pose(robot.x + camera_forward * cos_h + r * cos_t,
                robot.y + camera_forward * sin_h + r * sin_t, facing)  # fmt: skip
    # By the robot's (x, y, heading), and by the sighting's (distance, bearing, facing).
    by_robot = np.array([[1.0, 0.0, -camera_forward * sin_h - r * sin_t],
                         [0.0, 1.0, camera_forward * cos_h + r * cos_t],
                         [0.0, 0.0, 1.0]])  # fmt: skip
    by_seen = np.array([[cos_t, -r * sin_t, 0.0], [sin_t, r * cos_t, 0.0], [0.0, 0.0, 1.0]])
    sigmas = camera_sigmas(noise, np.array(r))
    if seen.facing_rad is None:
        by_seen[2] = 0.0, 1.0, 1.0  # back along the bearing, give or take the assumption's
        sigmas[2] = UNSEEN_FACING_SIGMA
    p = np.asarray(covariance, dtype=float)
    marker = by_robot @ p @ by_robot.T + by_seen @ np.diag(sigmas**2) @ by_seen.T
    return MarkerGuess(pose, (marker + marker.T) / 2, by_robot @ p, seen.facing_rad is not None)


def solve_survey(survey: Survey, *, start: SurveyResult | None = None) -> SurveyResult:
    """Every marker's pose and covariance, and the path, from one survey (see the module
    docstring); from `start`, a solution of the same survey (the same keyframes, casters'
    turns and markers) with other priors, instead of making a start: solving again with
    walls found (survey_walls.py) takes a few steps from there. ValueError for a survey
    that does not hang together (an edge naming no casters' turn, a sighting from no
    keyframe or without a distance, a covariance that is not one, a wall without
    length) or a `start` that is not its solution."""
    graph, sightings = _graph(survey)
    x = _start(survey, graph, sightings, start)
    active = activity(graph, Rejected.nothing(graph))
    x, robust_steps, _ = gauss_newton(graph, x, active, ROBUST_ITERATIONS, robust=True)
    rejected = outliers(graph, x)
    active = activity(graph, rejected)
    x, final_steps, converged = gauss_newton(graph, x, active, FINAL_ITERATIONS, robust=False)
    return _result(survey, graph, x, active, sightings, rejected, robust_steps + final_steps,
                   converged)  # fmt: skip


def _graph(survey: Survey) -> tuple[Graph, list[Sighting]]:
    """The graph of a survey, checked; and its sightings as the graph takes them."""
    edges = list(survey.odometry)
    count = len(edges) + 1
    casters = list(survey.caster_turns)
    for k, edge in enumerate(edges):
        if edge.caster is not None and not 0 <= edge.caster < len(casters):
            raise ValueError(f"odometry edge {k}: there is no casters' turn {edge.caster}")
    for j, turn in enumerate(casters):
        if not turn.sigma > 0:
            raise ValueError(f"casters' turn {j}: its sigma must be positive")
    sightings = []
    for i, s in enumerate(survey.sightings):
        if not 0 <= s.keyframe < count:
            raise ValueError(f"sighting {i}: there is no keyframe {s.keyframe} (of {count})")
        sightings.append(replace(s, seen=prepared(s.seen, f"sighting {i}")))
    markers = sorted({s.seen.marker_id for s in sightings} | set(survey.known))
    covariances = np.array([e.covariance for e in edges], dtype=float).reshape(-1, 3, 3)
    edge_data = EdgeData(
        motion=np.array([[e.motion.x, e.motion.y, e.motion.heading] for e in edges]).reshape(-1, 3),
        covariance=covariances,
        whiten=whiteners(covariances, "odometry edge"),
        caster=np.array([-1 if e.caster is None else e.caster for e in edges], dtype=int),
        release=np.array([e.release for e in edges], dtype=float),
        sway=np.array([e.sway for e in edges], dtype=float),
    )
    caster_data = CasterData(
        expected=np.array([c.expected for c in casters], dtype=float),
        sigma=np.array([c.sigma for c in casters], dtype=float),
        carried=np.array([c.carried for c in casters], dtype=float),
    )
    graph = Graph(count, markers, (survey.start.pose, np.asarray(survey.start.covariance)),
                  edge_data, caster_data, [(s.keyframe, s.seen) for s in sightings],
                  survey.noise, survey.camera_forward)  # fmt: skip
    return graph, sightings


def _start(survey: Survey, graph: Graph, sightings: list[Sighting],
           previous: SurveyResult | None) -> np.ndarray:  # fmt: skip
    """Where Gauss-Newton starts (pose_graph_start.py, or `previous`), with the priors on
    markers set: each wall's normal turned to the side its marker was seen from."""
    known = {i: (p.pose, np.asarray(p.covariance, dtype=float)) for i, p in survey.known.items()}
    seen = {s.seen.marker_id for s in sightings}
    walls = {i: wall for i, wall in survey.walls.items() if i in seen}
    ids = sorted(walls)
    normals = np.array([_left_of(walls[i], i) for i in ids]).reshape(-1, 2)
    graph.hold(WallData(np.array([graph.marker_index[i] for i in ids], dtype=int),
                        np.array([walls[i].a for i in ids], dtype=float).reshape(-1, 2), normals,
                        np.array([(walls[i].sigma_m, walls[i].sigma_facing) for i in ids],
                                 dtype=float).reshape(-1, 2)), known, {})  # fmt: skip
    wall_facings = {i: (math.atan2(n[1], n[0]), walls[i].sigma_facing)
                    for i, n in zip(ids, normals, strict=True)}  # fmt: skip
    if previous is None:
        observed = [(s.keyframe, s.seen) for s in sightings]
        x = starting_point(graph, survey.start.pose, np.asarray(survey.start.covariance),
                           observed, wall_facings, known)  # fmt: skip
    else:
        x = _from(previous, graph)
    keyframes, _, markers = graph.split(x)
    seen_from: dict[int, list[int]] = {}
    faced = set(known)
    for s in sightings:
        seen_from.setdefault(s.seen.marker_id, []).append(s.keyframe)
        if s.seen.facing_rad is not None:
            faced.add(s.seen.marker_id)
    # Each observer counts once, however far: a misread from across the building must
    # not turn a marker, or its wall's side, round.
    seen_facing = {}
    for marker_id, frames in seen_from.items():
        back = keyframes[frames, :2] - markers[graph.marker_index[marker_id], :2]
        back /= np.maximum(np.linalg.norm(back, axis=1), 1e-9)[:, None]
        way = back.mean(axis=0)
        seen_facing[marker_id] = math.atan2(way[1], way[0])
        if marker_id not in faced:
            markers[graph.marker_index[marker_id], 2] = seen_facing[marker_id]
    for w, marker_id in enumerate(ids):
        observers = keyframes[seen_from[marker_id], :2] - graph.walls.point[w]
        if np.sign(observers @ normals[w]).sum() < 0:  # most saw it from the other side
            normals[w] = -normals[w]
        if marker_id not in faced:
            markers[graph.marker_index[marker_id], 2] = math.atan2(normals[w, 1], normals[w, 0])
    graph.hold(replace(graph.walls, normal=normals), known, seen_facing)
    return x


def _from(previous: SurveyResult, graph: Graph) -> np.ndarray:
    """The unknowns as a solution of the same survey left them."""
    if (len(previous.keyframes) != graph.keyframes or
            len(previous.caster_turns) != len(graph.casters.expected) or
            set(previous.markers) != set(graph.marker_ids)):  # fmt: skip
        raise ValueError("the start given is not a solution of this survey: its keyframes, "
                         "casters' turns or markers differ")  # fmt: skip
    x = np.zeros(graph.size)
    keyframes, casters, markers = graph.split(x)
    keyframes[:] = [(k.x, k.y, k.heading) for k in previous.keyframes]
    casters[:] = previous.caster_turns
    for i, marker_id in enumerate(graph.marker_ids):
        m = previous.markers[marker_id].pose
        markers[i] = m.x, m.y, m.heading
    return x


def _left_of(wall: Wall, marker_id: int) -> np.ndarray:
    """The unit normal on the left of the wall from a to b."""
    along = np.array(wall.b, dtype=float) - np.array(wall.a, dtype=float)
    length = float(np.linalg.norm(along))
    if not length > 0:
        raise ValueError(f"marker {marker_id}: its wall has no length")
    return np.array([-along[1], along[0]]) / length


def _result(survey: Survey, graph: Graph, x: np.ndarray, active: np.ndarray,
            sightings: list[Sighting], rejected: Rejected, iterations: int,
            converged: bool) -> SurveyResult:  # fmt: skip
    keyframes, casters, markers = graph.split(x)
    solved = covariances(graph, x, active, len(keyframes) - 1)
    joint = solved.markers
    each = [joint[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] for i in range(len(graph.marker_ids))]
    rows = active[graph.rows["sightings"]].reshape(-1, 3)
    used = np.bincount(graph.sighting_marker, weights=rows[:, 0],
                       minlength=len(graph.marker_ids))  # fmt: skip
    faced = set(survey.known) | {s.seen.marker_id for i, s in enumerate(sightings)
                                 if s.seen.facing_rad is not None and rows[i, 2] > 0}  # fmt: skip
    kept = {graph.marker_ids[m]: bool(k) for m, k in zip(graph.walls.marker, rejected.walls_kept,
                                                         strict=True)}  # fmt: skip
    faced |= {i for i, k in kept.items() if k}
    surveyed = {
        marker_id: SurveyedMarker(
            marker_id, Pose(float(m[0]), float(m[1]), wrap(float(m[2]))), each[i],
            int(used[i]), marker_id in faced,
            survey.walls[marker_id] if kept.get(marker_id) else None,
            marker_id in kept and not kept[marker_id])
        for i, (marker_id, m) in enumerate(zip(graph.marker_ids, markers, strict=True))
    }  # fmt: skip
    r = graph.residuals(x)[graph.rows["sightings"]].reshape(-1, 3)
    errors = r * graph.sighting_sigmas
    left_out = tuple(
        Outlier(sightings[i], float(r[i, 2] ** 2 if i in rejected.facings else r[i] @ r[i]),
                (float(errors[i, 0]), float(errors[i, 1]),
                 float(errors[i, 2]) if graph.has_facing[i] else None),
                facing_only=i in rejected.facings)
        for i in sorted(rejected.sightings | rejected.facings)
    )  # fmt: skip
    return SurveyResult(
        markers=surveyed,
        keyframes=tuple(Pose(float(k[0]), float(k[1]), wrap(float(k[2]))) for k in keyframes),
        last_covariance=solved.keyframe,
        outliers=left_out,
        caster_turns=tuple(float(c) for c in casters),
        unseen=tuple(sorted(set(survey.walls) - set(surveyed))),
        iterations=iterations,
        converged=converged,
        joint_covariance=joint,
    )
