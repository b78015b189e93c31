"""Where the survey's Gauss-Newton starts (pose_graph.py): headings first, then positions,
each one sparse linear least-squares solve.

Why not the online filter's poses
    A survey starts with no marker known, so the online filter's poses are dead
    reckoning, and each turn on the spot leaves the casters' unseen turn (up to 45
    degrees, §3.2.1.5) in them: after a room or two they are tens of degrees and metres
    off, and Gauss-Newton from there settles in a wrong minimum. Nor a robot localising
    on the map it makes as it goes: it maps each new marker where its own drifted pose
    says, and keeps that drift (on a 30-room synthetic survey it ended 80 m off).

Why headings first (the linear approximation of Carlone et al., "LAGO", 2012)
    In this graph the headings alone are linear: an edge turns the heading by what the
    wheels say plus its share of the casters' turn, a sighting's facing is the marker's
    facing less the robot's heading, a wall gives a marker's facing. Only the 2 pi each
    angle may be off by is not: a pass along the path picks it for each sighting, with a
    heading-only filter corrected by the markers' facings as they are mapped (it needs
    to stay within half a turn, which a few markers a room keep it to, not within
    centimetres). Then one global solve gives every heading and facing at once, each
    room's tied to the markers it shares with the corridor.
    Given the headings, the positions are linear too: an edge moves the robot by its
    wheels' travel turned by the heading, a sighting puts the marker at its distance
    along its bearing. A second solve gives them.
    Both solves weigh sightings by Cauchy's loss, reweighted a few times, so that a
    misread marker does not bend the start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from giraff_console.robot.ekf import Observation, wrap
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph_model import Graph, clamped_caster_means

# The heading-only filter: a correction further off than this many sigmas is a misread
# (its branch of 2 pi is still picked, and the global solve down-weighs it).
HEADING_GATE_SIGMAS = 4.0
# A marker's facing as first mapped, before the global solve: known to about this.
MAPPED_FACING_SIGMA = math.radians(6.0)
# What is left of the headings' error in the position solve: a bearing is turned by it.
HEADING_LEFT = math.radians(2.0)
# Reweightings of the robust linear solves, Cauchy's scale in sigmas, and the least
# weight a row keeps (a marker whose only facing the filter's gate rejected must still
# have a facing to solve for).
REWEIGHTINGS = 4
CAUCHY_SCALE = 3.0
LEAST_WEIGHT = 1e-4


def starting_point(graph: Graph, start: Pose, start_covariance: np.ndarray,
                   sightings: Sequence[tuple[int, Observation]],
                   wall_facings: Mapping[int, tuple[float, float]],
                   known: Mapping[int, tuple[Pose, np.ndarray]]) -> np.ndarray:  # fmt: skip
    """The graph's unknowns (pose_graph_model.Graph's layout) to start Gauss-Newton from.
    `wall_facings`: per marker, its wall's normal direction (either side: the facing
    picks it) and the standard deviation of its facing; `known` the markers already
    mapped, pose and covariance."""
    x = np.zeros(graph.size)
    keyframes, casters, markers = graph.split(x)
    expected = _caster_means(graph)
    casters[:] = expected
    branches, weights, mapped = _branches(graph, start, start_covariance, sightings, expected,
                                          wall_facings, known)  # fmt: skip
    headings, caster_turns, facings, weights = _headings(
        graph, start, start_covariance, branches, weights, wall_facings, known, mapped, expected
    )
    keyframes[:, 2] = headings
    casters[:] = caster_turns
    for i, facing in facings.items():
        markers[i, 2] = facing
    positions, marker_positions = _positions(graph, x, start, start_covariance, known, weights)
    keyframes[:, :2] = positions
    markers[:, :2] = marker_positions
    return x


def _caster_means(graph: Graph) -> np.ndarray:
    """Each casters' turn's prior mean, what was carried over included, within the
    casters' worst (pose_graph_model.CasterData)."""
    prior = graph.casters
    worst = graph.noise.caster_worst
    means = np.zeros(len(prior.expected))
    for j in range(len(means)):
        mean = prior.expected[j] + (prior.carried[j] * means[j - 1] if j else 0.0)
        means[j] = max(-worst, min(worst, mean))
    return means


def _branches(graph: Graph, start: Pose, start_covariance: np.ndarray,
              sightings: Sequence[tuple[int, Observation]], casters: np.ndarray,
              wall_facings: Mapping[int, tuple[float, float]],
              known: Mapping[int, tuple[Pose, np.ndarray]],
              ) -> tuple[np.ndarray, np.ndarray, dict[int, float]]:  # fmt: skip
    """Each sighting's facing unwrapped (nan without one) and its starting weight (0 for
    one the filter's gate rejected), by a heading-only filter along the path; and each
    marker's facing as mapped, unwrapped the same way.

    A marker is mapped from its first sighting with a facing; if more of its later
    sightings then disagree with that than agree (a misread id mapped it), it is mapped
    again from the one that disagrees."""
    edges = graph.edges
    by_keyframe: list[list[int]] = [[] for _ in range(graph.keyframes)]
    for i, (k, seen) in enumerate(sightings):
        if seen.facing_rad is not None:
            by_keyframe[k].append(i)
    sigma_f = graph.noise.facing
    mapped: dict[int, float] = {}
    votes: dict[int, list[float]] = {}  # per marker: sightings agreeing, disagreeing
    for marker_id, (pose, _) in known.items():
        mapped[graph.marker_index[marker_id]] = pose.heading
        votes[graph.marker_index[marker_id]] = [math.inf, 0]  # known: never mapped again
    headings = np.zeros(graph.keyframes)
    heading, variance = start.heading, float(start_covariance[2, 2])
    for k in range(graph.keyframes):
        if k:
            j = edges.caster[k - 1]
            release = edges.release[k - 1] if j >= 0 else 0.0
            heading += edges.motion[k - 1, 2] + release * (casters[j] if j >= 0 else 0.0)
            spread = release * graph.casters.sigma[j] if j >= 0 else 0.0
            variance += edges.covariance[k - 1, 2, 2] + spread**2
        for i in by_keyframe[k]:
            m = graph.sighting_marker[i]
            facing = _facing(sightings[i][1])
            if m not in mapped:
                mapped[m] = _on_wall(heading + facing, wall_facings.get(graph.marker_ids[m]))
                votes[m] = [1, 0]
                continue
            innovation = wrap(mapped[m] - facing - heading)
            s = variance + sigma_f**2 + MAPPED_FACING_SIGMA**2
            if abs(innovation) < HEADING_GATE_SIGMAS * math.sqrt(s):
                votes[m][0] += 1
                gain = variance / s
                heading += gain * innovation
                variance *= 1 - gain
            else:
                votes[m][1] += 1
                if votes[m][1] > votes[m][0]:
                    mapped[m] = _on_wall(heading + facing, wall_facings.get(graph.marker_ids[m]))
                    votes[m] = [1, 0]
        headings[k] = heading
    unwrapped = np.full(len(sightings), np.nan)
    weights = np.ones(len(sightings))
    for k, row in enumerate(by_keyframe):
        for i in row:
            m = graph.sighting_marker[i]
            facing = _facing(sightings[i][1])
            off = wrap(mapped[m] - headings[k] - facing)
            unwrapped[i] = mapped[m] - off - headings[k]
            if abs(off) > HEADING_GATE_SIGMAS * math.hypot(sigma_f, MAPPED_FACING_SIGMA):
                weights[i] = 0.0
    return unwrapped, weights, mapped


def _facing(seen: Observation) -> float:
    assert seen.facing_rad is not None
    return seen.facing_rad


def _on_wall(facing: float, wall: tuple[float, float] | None) -> float:
    """A new marker's facing: as seen, or its wall's normal on the side nearest that,
    on the same turn as the facing seen."""
    if wall is None:
        return facing
    off = wrap(wall[0] - facing)
    return facing + (off if abs(off) <= math.pi / 2 else wrap(off + math.pi))


def _headings(graph: Graph, start: Pose, start_covariance: np.ndarray, branches: np.ndarray,
              weights: np.ndarray, wall_facings: Mapping[int, tuple[float, float]],
              known: Mapping[int, tuple[Pose, np.ndarray]], mapped: dict[int, float],
              means: np.ndarray,
              ) -> tuple[np.ndarray, np.ndarray, dict[int, float], np.ndarray]:  # fmt: skip
    """Every keyframe's heading, casters' turn and mapped marker's facing, from the
    graph's linear heading rows (module docstring), starting from the sightings'
    `weights`; and each sighting's weight at the end (1 for those without a facing).
    `means`: the casters' turns' prior means (_caster_means)."""
    k_count, c_count = graph.keyframes, len(graph.casters.expected)
    faced = sorted(mapped)
    column = np.full(len(graph.marker_ids), -1)
    column[faced] = k_count + c_count + np.arange(len(faced))
    rows = _Rows(k_count + c_count + len(faced))
    rows.add([[0]], [[1.0]], [start.heading], [math.sqrt(start_covariance[2, 2])])
    edges = graph.edges
    k = np.arange(len(edges.caster))
    has_caster = edges.caster >= 0
    rows.add(np.stack([k + 1, k, np.where(has_caster, k_count + edges.caster, 0)], 1),
             np.stack([np.ones(len(k)), -np.ones(len(k)), -edges.release * has_caster], 1),
             edges.motion[:, 2], np.sqrt(edges.covariance[:, 2, 2]))  # fmt: skip
    # The casters' priors, linear about their means: a turn held at the worst no longer
    # follows the one before.
    prior = graph.casters
    j = np.arange(c_count)
    before = np.concatenate([[0.0], means[:-1]])
    _, free = clamped_caster_means(prior, before, graph.noise.caster_worst)
    carried = np.where(j > 0, prior.carried, 0.0) * free
    rows.add(np.stack([k_count + j, k_count + np.maximum(j - 1, 0)], 1),
             np.stack([np.ones(c_count), -carried], 1), means - carried * before,
             prior.sigma)  # fmt: skip
    held = [(graph.marker_index[i], math.sqrt(c[2, 2])) for i, (_, c) in known.items()]
    held += [(graph.marker_index[i], sigma) for i, (_, sigma) in wall_facings.items()
             if column[graph.marker_index[i]] >= 0]  # fmt: skip
    for m, sigma in held:
        rows.add([[column[m]]], [[1.0]], [mapped[m]], [sigma])
    robust_from = rows.count
    with_facing = np.flatnonzero(np.isfinite(branches))
    rows.add(np.stack([column[graph.sighting_marker[with_facing]],
                       graph.sighting_keyframe[with_facing]], 1),
             np.tile([1.0, -1.0], (len(with_facing), 1)), branches[with_facing],
             np.full(len(with_facing), graph.noise.facing))  # fmt: skip
    solution, solved = rows.solve(robust_from, weights[with_facing])
    weights = np.ones(len(branches))
    weights[with_facing] = solved
    return (solution[:k_count], solution[k_count:k_count + c_count],
            {m: float(solution[column[m]]) for m in faced}, weights)  # fmt: skip


def _positions(graph: Graph, x: np.ndarray, start: Pose, start_covariance: np.ndarray,
               known: Mapping[int, tuple[Pose, np.ndarray]],
               weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Every keyframe's and marker's position, the headings in `x` taken as known, the
    sightings starting from `weights` (the heading solve's). Each row pair is whitened
    by W = L^-1 R', for the covariance R L L' R' of a displacement seen turned by R."""
    keyframes, casters, _ = graph.split(x)
    k_count = graph.keyframes
    rows = _Rows(2 * (k_count + len(graph.marker_ids)))
    start_whiten = np.linalg.inv(np.linalg.cholesky(start_covariance[:2, :2]))
    rows.pairs(np.array([0]), None, start_whiten[None], np.array([[start.x, start.y]]))
    edges = graph.edges
    k = np.arange(len(edges.caster))
    c = np.where(edges.caster >= 0, casters[np.maximum(edges.caster, 0)] if len(casters) else 0, 0)
    travel = np.einsum("eij,ej->ei", _rotations(keyframes[k, 2] + edges.sway * c),
                       edges.motion[:, :2])  # fmt: skip
    whiten = np.linalg.inv(np.linalg.cholesky(edges.covariance[:, :2, :2]))
    rows.pairs(2 * (k + 1), 2 * k, whiten @ _rotations(-keyframes[k, 2]), travel)
    for marker_id, (pose, covariance) in known.items():
        at = 2 * (k_count + graph.marker_index[marker_id])
        rows.pairs(np.array([at]), None,
                   np.linalg.inv(np.linalg.cholesky(covariance[:2, :2]))[None],
                   np.array([[pose.x, pose.y]]))  # fmt: skip
    walls = graph.walls
    across = walls.normal / walls.sigma[:, :1]
    first = 2 * (k_count + walls.marker)
    rows.add(np.stack([first, first + 1], 1), across,
             np.einsum("wi,wi->w", across, walls.point), np.ones(len(first)))  # fmt: skip
    robust_from = rows.count
    distance, bearing = graph.sighting_seen[:, 0], graph.sighting_seen[:, 1]
    heading = keyframes[graph.sighting_keyframe, 2]
    towards = _rotations(heading + bearing)
    offset = graph.camera_forward * np.stack([np.cos(heading), np.sin(heading)], 1)
    offset += towards[:, :, 0] * distance[:, None]
    sigmas = graph.sighting_sigmas
    scale = np.stack([1 / sigmas[:, 0], 1 / (distance * np.hypot(sigmas[:, 1], HEADING_LEFT))], 1)
    rows.pairs(2 * (k_count + graph.sighting_marker), 2 * graph.sighting_keyframe,
               scale[:, :, None] * np.swapaxes(towards, 1, 2), offset)  # fmt: skip
    solution, _ = rows.solve(robust_from, np.repeat(weights, 2))
    return solution[: 2 * k_count].reshape(-1, 2), solution[2 * k_count :].reshape(-1, 2)


def _rotations(angles: np.ndarray) -> np.ndarray:
    """(n, 2, 2) rotation matrices."""
    c, s = np.cos(angles), np.sin(angles)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


class _Rows:
    """Whitened linear rows a x = b, gathered in blocks, solved by reweighted least
    squares: Cauchy's weights on the rows from `robust_from` on."""

    def __init__(self, unknowns: int) -> None:
        self.unknowns = unknowns
        self.count = 0
        self._cols: list[np.ndarray] = []
        self._rows: list[np.ndarray] = []
        self._values: list[np.ndarray] = []
        self._b: list[np.ndarray] = []

    def add(self, cols: ArrayLike, coefficients: ArrayLike, values: ArrayLike,
            sigmas: ArrayLike) -> None:  # fmt: skip
        """One row per item: sum of coefficients times the unknowns in `cols` = value,
        each to its sigma."""
        cols, coefficients = np.asarray(cols, dtype=int), np.asarray(coefficients, dtype=float)
        sigmas = np.asarray(sigmas, dtype=float)
        n = len(cols)
        self._rows.append(np.repeat(self.count + np.arange(n), cols.shape[1]))
        self._cols.append(cols.ravel())
        self._values.append((coefficients / sigmas[:, None]).ravel())
        self._b.append(np.asarray(values, dtype=float) / sigmas)
        self.count += n

    def pairs(self, later: np.ndarray, earlier: np.ndarray | None, whiten: np.ndarray,
              value: np.ndarray) -> None:  # fmt: skip
        """Two rows per item: whiten @ (the x, y at `later` less those at `earlier`, if
        any) = whiten @ value."""
        terms = [(later, whiten)] + ([] if earlier is None else [(earlier, -whiten)])
        cols = np.concatenate(
            [
                np.broadcast_to((first[:, None] + np.arange(2))[:, None, :], (len(first), 2, 2))
                for first, _ in terms
            ],
            2,
        )
        coefficients = np.concatenate([w for _, w in terms], 2)
        values = np.einsum("nij,nj->ni", whiten, value)
        for r in range(2):
            self.add(cols[:, r], coefficients[:, r], values[:, r], np.ones(len(later)))

    def solve(self, robust_from: int, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solution, and the robust rows' weights at the end, starting from `weights`."""
        # Imported at the first solve, not with the module: scipy costs the console's start
        # a quarter of a second, and only a survey solves (issue 26, item 6).
        from scipy import sparse  # type: ignore[import-untyped]
        from scipy.sparse.linalg import splu  # type: ignore[import-untyped]

        a = sparse.csr_matrix((np.concatenate(self._values),
                               (np.concatenate(self._rows), np.concatenate(self._cols))),
                              shape=(self.count, self.unknowns))  # fmt: skip
        b = np.concatenate(self._b)
        weights = np.concatenate([np.ones(robust_from), weights])
        solution = np.zeros(self.unknowns)
        weights = np.maximum(weights, LEAST_WEIGHT)
        for _ in range(REWEIGHTINGS):
            weighted = sparse.diags(weights) @ a
            factor = splu((a.T @ weighted).tocsc(), permc_spec="MMD_AT_PLUS_A",
                          diag_pivot_thresh=0.0, options={"SymmetricMode": True})  # fmt: skip
            solution = factor.solve(weighted.T @ b)
            r = (a @ solution - b)[robust_from:]
            weights[robust_from:] = np.maximum(1 / (1 + (r / CAUCHY_SCALE) ** 2), LEAST_WEIGHT)
        return solution, weights[robust_from:]
