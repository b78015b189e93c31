"""Gauss-Newton on a survey's pose graph, its outliers, and its markers' covariances
(pose_graph.py's numerical core; the residuals are pose_graph_model.py's).

Why Gauss-Newton with a sparse LU here, and not scipy's least_squares
    least_squares, given a sparse Jacobian, can only use its trust-region methods with
    LSMR, an iterative solver, for each step. On a pose graph (a long chain whose
    conditioning worsens with its length) LSMR's inexact steps leave it short of the
    minimum: on a synthetic 30-room survey (bench/pose_graph.py), from the same start and
    with the same analytic Jacobian and Cauchy's loss, 100 evaluations (1.3 s) took the
    markers from 8.8 to 8.2 cm at p95, where Gauss-Newton, each step one sparse LU of the
    normal matrix (SuperLU, scipy.sparse.linalg.splu, 25 ms), reached 3.9 cm in 11 steps
    (0.7 s with the covariances). Its robust losses also apply the Triggs correction,
    which zeroes the Jacobian rows of every residual beyond the loss's scale: at a start
    decimetres off, most of the sightings. So the robust loss is applied here by
    reweighting (IRLS): each sighting's distance and bearing, and its facing, weighted
    1 / (1 + d^2 / s^2) for Cauchy's loss on their squared Mahalanobis distance, the
    weights renewed at every step. (The Jacobian
    is analytic and sparse, pose_graph_model.py; least_squares' jac_sparsity is for
    finite differences, which would take a few dozen residual evaluations a step.)
    Dense normal equations (numpy) take 22 s a step at that size, and 1.2 GB.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from giraff_console.robot.ekf import CHI_SQUARE
from giraff_console.robot.pose_graph_model import Graph

if TYPE_CHECKING:
    from scipy import sparse  # type: ignore[import-untyped]

# The robust loss's scale, in standard deviations: a sighting further off than this
# counts for less and less (Cauchy), so one misread marker cannot drag the rest.
ROBUST_SCALE = 3.0
# A sighting (or wall) whose squared Mahalanobis distance at the solution passes this
# chi-square quantile is an outlier: one good sighting in a thousand is lost.
OUTLIER_CONFIDENCE = 0.999
# Gauss-Newton: steps at most (the robust solve, the last), how often a step that made
# things worse is halved, the damping after that (a multiple of the normal matrix's
# diagonal), and when it has converged: the cost down by less than this fraction, or no
# unknown moved by more than this (a tenth of a millimetre, of a milliradian: nothing
# against centimetres, and each step more is a factorisation, 30 ms at 30 rooms).
ROBUST_ITERATIONS = 50
FINAL_ITERATIONS = 20
HALVINGS = 3
MIN_DAMPING = 1e-6
MAX_DAMPING = 1e10
CONVERGED_DECREASE = 1e-7
CONVERGED_STEP = 1e-4
# Right-hand sides per sparse solve for the markers' covariances (see `covariances`).
SOLVE_COLUMNS = 32


def _factor(matrix: sparse.spmatrix) -> Any:
    """SuperLU of a symmetric positive definite matrix: a fill-reducing ordering of A + A'
    and the diagonal as pivots, as for a Cholesky factor."""
    # Imported at the first solve, not with the module: scipy costs the console's start
    # a quarter of a second, and only a survey solves (issue 26, item 6).
    from scipy import sparse  # type: ignore[import-untyped]
    from scipy.sparse.linalg import splu  # type: ignore[import-untyped]

    return splu(sparse.csc_matrix(matrix), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True})  # fmt: skip


def gauss_newton(graph: Graph, x: np.ndarray, active: np.ndarray, iterations: int,
                 robust: bool) -> tuple[np.ndarray, int, bool]:  # fmt: skip
    """Gauss-Newton on the active rows; with `robust`, Cauchy's loss on each sighting's
    distance and bearing, and its facing, apart (outliers says why), and on each wall
    and known marker as a whole. The point reached, the steps taken, and whether it
    converged.

    A step that makes the cost worse is halved (a few times), then damped as
    Levenberg-Marquardt. Halving first matters: without walls, the whole map turning
    about the dock is held only by the dock's 3 degrees, a direction a million times
    flatter than the rest. Gauss-Newton's step along it moves markers 60 m away along
    their tangent, which stretches the map and costs more than the turn saves; half a
    step stretches it a quarter as much. Damping in proportion to the normal matrix's
    diagonal would instead crawl along that direction for a hundred steps."""
    from scipy import sparse  # type: ignore[import-untyped]  # see _factor

    damping = 0.0
    cost, weights, r = _cost(graph, x, active, robust)
    for iteration in range(1, iterations + 1):
        j = graph.jacobian(x, active)
        weighted = sparse.diags(weights) @ j
        normal = (j.T @ weighted).tocsc()
        gradient = weighted.T @ r
        diagonal = sparse.diags(normal.diagonal())
        while True:
            step = _factor(normal + damping * diagonal).solve(-gradient)
            for _ in range(HALVINGS + 1):
                trial = x + step
                trial_cost, trial_weights, trial_r = _cost(graph, trial, active, robust)
                if trial_cost <= cost:
                    break
                step = step / 2
            if trial_cost <= cost:
                break
            damping = max(damping * 10, MIN_DAMPING)
            if damping > MAX_DAMPING:
                return x, iteration, True  # no step makes it better: at the minimum
        decrease = cost - trial_cost
        x, cost, weights, r = trial, trial_cost, trial_weights, trial_r
        damping = damping / 10 if damping > MIN_DAMPING else 0.0
        if decrease <= CONVERGED_DECREASE * cost or np.abs(step).max() < CONVERGED_STEP:
            return x, iteration, True
    return x, iterations, False


def _cost(graph: Graph, x: np.ndarray, active: np.ndarray,
          robust: bool) -> tuple[float, np.ndarray, np.ndarray]:  # fmt: skip
    """The cost at `x`, each row's weight, and the residuals (active rows only). With
    `robust`, the rows from graph.robust_from on come in blocks (a sighting's distance
    and bearing, its facing, a wall, a known marker: graph.robust_blocks), each costing
    s^2 log(1 + d^2 / s^2) for its squared Mahalanobis distance d^2 at the scale
    s = ROBUST_SCALE, and so weighted 1 / (1 + d^2 / s^2)."""
    r = graph.residuals(x, active)
    weights = np.ones(len(r))
    if not robust:
        return 0.5 * float(r @ r), weights, r
    start = graph.robust_from
    block = graph.robust_blocks
    d2 = np.bincount(block, weights=r[start:] ** 2, minlength=int(block.max(initial=-1)) + 1)
    scale2 = ROBUST_SCALE**2
    weights[start:] = 1 / (1 + d2[block] / scale2)
    cost = 0.5 * float(r[:start] @ r[:start]) + 0.5 * scale2 * float(np.log1p(d2 / scale2).sum())
    return cost, weights, r


@dataclass(frozen=True)
class Rejected:
    """What the outlier bound leaves out at a solution: whole sightings (their distance
    and bearing beyond it), the facings alone of others (their distance and bearing
    within it), and which walls hold."""

    sightings: frozenset[int]
    facings: frozenset[int]
    walls_kept: np.ndarray

    @classmethod
    def nothing(cls, graph: Graph) -> Rejected:
        return cls(frozenset(), frozenset(), np.ones(len(graph.walls.marker), dtype=bool))


def outliers(graph: Graph, x: np.ndarray) -> Rejected:
    """The sightings beyond the outlier bound at `x`, and which walls hold (2 degrees
    of freedom each). A sighting's distance and bearing (2) and its facing (1) are
    judged apart: a small marker read from far off or askew can give its facing wrong,
    flipped about its plane, while where it is comes right (camera/markers.py); thrown
    out whole, such a sighting took with it the one tie between a dead-end room's new
    markers and the corridor's known ones. A marker whose every sighting (or every
    facing) is beyond the bound keeps them (they are all there is of it), and its wall
    is what gives way."""
    r = graph.residuals(x)[graph.rows["sightings"]].reshape(-1, 3)
    bound = CHI_SQUARE[OUTLIER_CONFIDENCE]
    whole = _all_kept_alone(graph, (r[:, :2] ** 2).sum(axis=1) > bound[2],
                            np.ones(len(r), dtype=bool))  # fmt: skip
    judged = graph.has_facing & ~whole
    facing = _all_kept_alone(graph, judged & (r[:, 2] ** 2 > bound[1]), judged)
    walls = graph.residuals(x)[graph.rows["walls"]].reshape(-1, 2)
    return Rejected(frozenset(int(i) for i in np.flatnonzero(whole)),
                    frozenset(int(i) for i in np.flatnonzero(facing)),
                    (walls**2).sum(axis=1) <= bound[2])  # fmt: skip


def _all_kept_alone(graph: Graph, beyond: np.ndarray, judged: np.ndarray) -> np.ndarray:
    """`beyond`, less the markers whose every `judged` sighting is beyond the bound."""
    beyond = beyond.copy()
    for marker in set(graph.sighting_marker[beyond]):
        own = (graph.sighting_marker == marker) & judged
        if beyond[own].all():
            beyond[own] = False
    return beyond


def activity(graph: Graph, rejected: Rejected) -> np.ndarray:
    """Each row's weight, 1 or 0: the rejected sightings, facings and walls out, and the
    weak prior on a marker's facing in only where nothing else says it."""
    rows = graph.rows
    active = np.ones(rows["known"].stop)
    sightings = active[rows["sightings"]].reshape(-1, 3)
    sightings[sorted(rejected.sightings)] = 0.0
    sightings[sorted(rejected.facings), 2] = 0.0
    kept = np.asarray(rejected.walls_kept, dtype=bool)
    active[rows["walls"]].reshape(-1, 2)[~kept] = 0.0
    faced = np.zeros(len(graph.marker_ids), dtype=bool)
    faced[graph.sighting_marker[graph.has_facing & (sightings[:, 2] > 0)]] = True
    faced[graph.walls.marker[kept]] = True
    faced[graph.known[0]] = True
    active[rows["unseen facing"]] = ~faced[graph.unseen_facing[0]]
    return active


@dataclass(frozen=True)
class Covariances:
    """The markers' joint covariance (3M x 3M, in graph.marker_ids' order) and one
    keyframe's 3x3 marginal covariance."""

    markers: np.ndarray
    keyframe: np.ndarray


def covariances(graph: Graph, x: np.ndarray, active: np.ndarray, keyframe: int) -> Covariances:
    """The markers' joint covariance and `keyframe`'s, from the Gauss-Newton normal
    matrix H = J'J at `x`: with the keyframes and casters (P) before the markers (M),
    the markers' is the inverse of the Schur complement S = H_MM - H_MP H_PP^-1 H_PM,
    and the keyframe's block of H^-1 is that of H_PP^-1 plus W S^-1 W', W its rows of
    H_PP^-1 H_PM. H_PP is sparse and nearly banded along the path, so one sparse LU of
    it serves both, solved for the markers' columns (a dense matrix only three times the
    markers across: 750 for 250) and the keyframe's three."""
    j = graph.jacobian(x, active).tocsc()
    p = graph.pose_size
    jp, jm = j[:, :p], j[:, p:]
    factor = _factor(jp.T @ jp)
    rows = 3 * keyframe + np.arange(3)
    unit = np.zeros((p, 3))
    unit[rows, np.arange(3)] = 1.0
    alone = factor.solve(unit)[rows]
    count = 3 * len(graph.marker_ids)
    if not count:
        return Covariances(np.zeros((0, 0)), (alone + alone.T) / 2)
    h_pm = (jp.T @ jm).tocsc()
    schur = (jm.T @ jm).toarray()
    through = np.zeros((3, count))
    # In slices of columns: SuperLU solves a few dozen right-hand sides at once many
    # times faster than hundreds (0.14 s against 6.7 s for 450 on a 30-room survey).
    for first in range(0, count, SOLVE_COLUMNS):
        cols = slice(first, min(first + SOLVE_COLUMNS, count))
        solved = factor.solve(np.asfortranarray(h_pm[:, cols].toarray()))
        schur[:, cols] -= h_pm.T @ solved
        through[:, cols] = solved[rows]
    markers = np.linalg.inv((schur + schur.T) / 2)
    markers = (markers + markers.T) / 2
    block = alone + through @ markers @ through.T
    return Covariances(markers, (block + block.T) / 2)
