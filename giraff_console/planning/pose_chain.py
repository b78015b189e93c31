"""A chain of planar poses tied by measured relative poses, solved by least squares: the
teaching map's loop closure (loop_closure.py) asks it where each keyframe of the drive
was, given the motion between neighbours and the places the drive came back to.

Pure numpy and scipy's sparse LU; no I/O. Each edge says "pose j, seen from pose i, is
at (dx, dy, dheading)" with a standard deviation for the distance and one for the
turn; its residual is the difference in i's frame, whitened. Gauss-Newton on the whole
chain, the first pose held where it is (the map's dock). Edges marked `robust` (a loop
closure may be wrong: a room that looks like another) are weighted by Cauchy's loss on
their squared Mahalanobis distance, renewed at every step (IRLS), as the survey's pose
graph weighs its sightings (robot/pose_graph_solve.py says why IRLS and not scipy's
least_squares); those left beyond the outlier bound at the end are dropped and the
chain solved once more without them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Cauchy's scale, in standard deviations, for the robust edges.
ROBUST_SCALE = 3.0
# A robust edge whose squared Mahalanobis distance (3 degrees of freedom) is beyond
# this at the solution is left out: chi-square's 99.9 % point.
OUTLIER_D2 = 16.27
ITERATIONS = 30
CONVERGED_STEP = 1e-5  # metres and radians
HELD = 1e12  # the first pose's prior, in the normal matrix's units


@dataclass(frozen=True)
class Edge:
    i: int
    j: int
    dx: float
    dy: float
    dheading: float
    sigma_m: float
    sigma_rad: float
    robust: bool = False


@dataclass(frozen=True)
class Solved:
    poses: np.ndarray  # (N, 3): x, y, heading
    iterations: int
    outliers: tuple[int, ...]  # the indices of the robust edges left out


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pose `b` (x, y, heading; arrays of them, (..., 3)) seen from pose `a`."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    turn = np.remainder(b[..., 2] - a[..., 2] + math.pi, math.tau) - math.pi
    return np.stack([c * dx + s * dy, -s * dx + c * dy, turn], axis=-1)


def compose(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Pose `a` moved by `d` in its own frame ((..., 3) each)."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * d[..., 0] - s * d[..., 1],
                     a[..., 1] + s * d[..., 0] + c * d[..., 1],
                     a[..., 2] + d[..., 2]], axis=-1)  # fmt: skip


def solve(start: np.ndarray, edges: list[Edge]) -> Solved:
    """The poses (N, 3) that best fit `edges`, from `start` (N, 3), the first held."""
    from scipy import sparse  # type: ignore[import-untyped]
    from scipy.sparse.linalg import spsolve  # type: ignore[import-untyped]

    x = np.array(start, dtype=float)
    count = len(x)
    if count < 2 or not edges:
        return Solved(x, 0, ())
    e = np.array([(d.i, d.j) for d in edges], dtype=np.intp)
    z = np.array([(d.dx, d.dy, d.dheading) for d in edges], dtype=float)
    w = np.array([(1 / d.sigma_m, 1 / d.sigma_m, 1 / d.sigma_rad) for d in edges])
    robust = np.array([d.robust for d in edges], dtype=bool)
    kept = np.ones(len(edges), dtype=bool)
    iterations = 0
    for final in (False, True):
        for _ in range(ITERATIONS):
            iterations += 1
            r, jac_i, jac_j = _linearised(x, e, z)
            r *= w
            jac_i *= w[:, :, None]
            jac_j *= w[:, :, None]
            d2 = np.sum(r * r, axis=1)
            weight = np.where(robust, 1 / (1 + d2 / ROBUST_SCALE**2), 1.0) * kept
            if final:
                weight = kept.astype(float)
            rows = np.repeat(np.arange(3 * len(e)), 3)
            cols_i = (3 * e[:, 0])[:, None, None] + np.arange(3)[None, None, :]
            cols_j = (3 * e[:, 1])[:, None, None] + np.arange(3)[None, None, :]
            cols_i = np.broadcast_to(cols_i, jac_i.shape).reshape(-1)
            cols_j = np.broadcast_to(cols_j, jac_j.shape).reshape(-1)
            jac = sparse.csr_matrix(
                (np.concatenate([jac_i.reshape(-1), jac_j.reshape(-1)]),
                 (np.concatenate([rows, rows]), np.concatenate([cols_i, cols_j]))),
                shape=(3 * len(e), 3 * count))  # fmt: skip
            weighted = sparse.diags(np.repeat(weight, 3)) @ jac
            # The first pose held: a prior far stiffer than any edge.
            held = np.zeros(3 * count)
            held[:3] = HELD
            normal = (jac.T @ weighted + sparse.diags(held)).tocsc()
            gradient = weighted.T @ r.reshape(-1)
            step = spsolve(normal, -gradient).reshape(count, 3)
            x += step
            if np.abs(step).max() < CONVERGED_STEP:
                break
        if final:
            break
        r, _, _ = _linearised(x, e, z)
        d2 = np.sum((r * w) ** 2, axis=1)
        kept = ~(robust & (d2 > OUTLIER_D2))
    return Solved(x, iterations, tuple(int(k) for k in np.flatnonzero(~kept)))


def _linearised(x: np.ndarray, e: np.ndarray,
                z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Each edge's residual (the relative pose of j from i less the measured one), and its
    Jacobians with respect to pose i and pose j, (E, 3) and (E, 3, 3) twice."""
    a, b = x[e[:, 0]], x[e[:, 1]]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    r = relative(a, b) - z
    r[:, 2] = np.remainder(r[:, 2] + math.pi, math.tau) - math.pi
    n = len(e)
    jac_i = np.zeros((n, 3, 3))
    jac_j = np.zeros((n, 3, 3))
    jac_i[:, 0, 0], jac_i[:, 0, 1] = -c, -s
    jac_i[:, 1, 0], jac_i[:, 1, 1] = s, -c
    jac_i[:, 0, 2] = -s * dx + c * dy
    jac_i[:, 1, 2] = -c * dx - s * dy
    jac_i[:, 2, 2] = -1.0
    jac_j[:, 0, 0], jac_j[:, 0, 1] = c, s
    jac_j[:, 1, 0], jac_j[:, 1, 1] = -s, c
    jac_j[:, 2, 2] = 1.0
    return r, jac_i, jac_j
