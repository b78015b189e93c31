"""The survey's pose graph as residuals and their sparse Jacobian (pose_graph.py solves it).

Pure and vectorised: one call evaluates every residual and the Jacobian of a 30-room
survey (some 3000 keyframes, 150 markers, 3000 sightings) in a few milliseconds.

The unknowns, in this order: each keyframe's pose (x, y, heading), each casters' turn
(one scalar per turn on the spot, §3.2.1.5), each marker's pose (x, y, facing). Every
residual is whitened (divided by its standard deviation, or multiplied by the inverse
Cholesky factor of its covariance), so that a residual of 1 is one sigma, the robust
loss can take one scale for all, and the Gauss-Newton normal matrix J'J is the
information matrix whose inverse is the covariance.

Rows come in two parts: first those that are never outliers (the dock, the wheels, the
casters' priors, and a weak prior on a facing nothing observes), then those that may be
(sightings, walls, markers already known): `robust_from` is where the second part starts,
so that the robust loss is applied to it alone (a wheel edge is never wrong the way a
misread marker is, and down-weighting one would break the chain).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from giraff_console.robot.ekf import FilterNoise, Observation, usable
from giraff_console.robot.odometry import Pose

if TYPE_CHECKING:
    from scipy import sparse  # type: ignore[import-untyped]

# A marker seen only without its facing, on no wall and not known: nothing observes its
# facing, so it is held, weakly, to face the robots that saw it (a printed marker is
# read only from within about 70 degrees of its normal, camera/markers.py).
UNSEEN_FACING_SIGMA = math.radians(45.0)


def wrap_angles(angles: np.ndarray) -> np.ndarray:
    """Angles in [-pi, pi): ekf.wrap for arrays."""
    return np.remainder(angles + math.pi, math.tau) - math.pi


def whiteners(covariances: np.ndarray, what: str) -> np.ndarray:
    """For each 3x3 covariance C in the stack, W with W' W = C^-1 (the inverse of its
    lower Cholesky factor): W e is a residual whose components are independent with
    unit variance. ValueError, naming `what` and which, unless each is symmetric
    positive definite."""
    c = np.asarray(covariances, dtype=float)
    if c.ndim != 3 or c.shape[1:] != (3, 3):
        raise ValueError(f"{what}: a covariance must be a 3x3 matrix")
    scale = np.maximum(1.0, np.abs(c).max(axis=(1, 2), initial=0.0))
    asymmetric = np.flatnonzero(np.abs(c - np.swapaxes(c, 1, 2)).max(axis=(1, 2), initial=0.0)
                                > 1e-12 * scale)  # fmt: skip
    if len(asymmetric):
        raise ValueError(f"{what} {asymmetric[0]}: its covariance is not symmetric")
    try:
        return np.asarray(np.linalg.inv(np.linalg.cholesky(c)))
    except np.linalg.LinAlgError:
        singular = np.flatnonzero(np.linalg.eigvalsh(c)[:, 0] <= 0)
        raise ValueError(
            f"{what} {singular[0] if len(singular) else ''}: its covariance "
            "is not positive definite"
        ) from None


# PRIVATE COPY of ekf.PoseFilter._measurement_noise's camera part (distance, bearing,
# facing), vectorised; until ekf.py has it as a public function. Without the marker's own
# placement terms (FilterNoise.marker_position, marker_facing): those are the plan's
# error in a marker's pose, and here the marker's pose is an unknown, not the plan's.
def camera_sigmas(noise: FilterNoise, distance: np.ndarray) -> np.ndarray:
    """The camera's standard deviations of (distance, bearing, facing) for sightings at
    these distances, one row each: solvePnP's depth from a 16 cm square, the bearing and
    the facing, as ekf.py's docstring says why."""
    d = np.maximum(np.asarray(distance, dtype=float), 1e-3)
    return np.stack(
        [noise.distance + noise.distance_fraction * d,
         np.full_like(d, noise.bearing), np.full_like(d, noise.facing)], axis=-1,
    )  # fmt: skip


@dataclass(frozen=True)
class EdgeData:
    """The wheels between keyframes k and k+1, k = 0..E-1, as arrays (pose_graph's
    OdometryEdge, one row each)."""

    motion: np.ndarray  # (E, 3): keyframe k+1 in k's frame, by the wheels alone
    covariance: np.ndarray  # (E, 3, 3)
    whiten: np.ndarray  # (E, 3, 3)
    caster: np.ndarray  # (E,) the casters' turn the edge releases, -1 for none
    release: np.ndarray  # (E,) its share released into the heading over the edge
    sway: np.ndarray  # (E,) its share the edge's travel is turned by, on average


@dataclass(frozen=True)
class CasterData:
    """Each casters' turn's prior: c_j ~ N(clamp(expected_j + carried_j c_j-1), sigma_j^2),
    clamped to the casters' worst either way as ekf.PoseFilter clamps the turn to come:
    a caster swung across cannot swing further, however many turns on the spot follow
    one another (unclamped, three look rounds in a row expected 60 degrees where the
    simulator's casters turned the robot their worst, 45, and a survey's graph put a
    dead-end room 15 degrees and 0.7 m off)."""

    expected: np.ndarray
    sigma: np.ndarray
    carried: np.ndarray


def clamped_caster_means(prior: CasterData, before: np.ndarray,
                         worst: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Each casters' turn's prior mean given the turns before (`before[j]` is c_j-1, 0 for
    the first), and whether it is within the worst (1.0) or held at it (0.0): how much
    it still follows the turn before."""
    mean = prior.expected + prior.carried * before
    free = (np.abs(mean) <= worst).astype(float)
    return np.clip(mean, -worst, worst), free


@dataclass(frozen=True)
class WallData:
    """Markers held to a wall's line (`normal` . (m - point) = 0) and facing its normal."""

    marker: np.ndarray  # (W,) marker index
    point: np.ndarray  # (W, 2) a point of the wall's line
    normal: np.ndarray  # (W, 2) the unit normal on the side the marker faces
    sigma: np.ndarray  # (W, 2) metres across the wall, radians of facing


class Graph:
    """The residuals and Jacobian of one survey's pose graph; see the module docstring.
    `active` (one weight per row, 1 or 0) leaves rows out without changing the
    Jacobian's structure: the solver drops outliers that way."""

    def __init__(self, keyframes: int, markers: Sequence[int], start: tuple[Pose, np.ndarray],
                 edges: EdgeData, casters: CasterData,
                 sightings: Sequence[tuple[int, Observation]], noise: FilterNoise,
                 camera_forward: float) -> None:  # fmt: skip
        self.keyframes = keyframes
        self.marker_ids = list(markers)
        self.marker_index = {marker_id: i for i, marker_id in enumerate(self.marker_ids)}
        self.casters = casters
        self.edges = edges
        self.camera_forward = camera_forward
        self.noise = noise
        self.pose_size = 3 * keyframes + len(casters.expected)
        self.size = self.pose_size + 3 * len(self.marker_ids)
        start_pose, start_covariance = start
        self._start = np.array([start_pose.x, start_pose.y, start_pose.heading])
        self._start_whiten = whiteners(np.array([start_covariance]), "the start")[0]
        # The sightings: keyframe, marker, measurement and standard deviations; a facing
        # not measured is a row of weight 0 (one shape for all keeps the code one path).
        n = len(sightings)
        self.sighting_keyframe = np.array([k for k, _ in sightings], dtype=int)
        self.sighting_marker = np.array(
            [self.marker_index[seen.marker_id] for _, seen in sightings], dtype=int
        )
        self.sighting_seen = np.zeros((n, 3))
        self.has_facing = np.zeros(n, dtype=bool)
        for i, (_, seen) in enumerate(sightings):
            self.sighting_seen[i] = seen.distance_m, seen.bearing_rad, seen.facing_rad or 0.0
            self.has_facing[i] = seen.facing_rad is not None
        self.sighting_sigmas = camera_sigmas(noise, self.sighting_seen[:, 0])
        # The priors on markers (`hold`): walls; known poses (index, pose, whitener);
        # the way each was seen from (index, facing).
        none = np.zeros(0, int)
        self.walls = WallData(none, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2)))
        self.known: tuple[np.ndarray, np.ndarray, np.ndarray] = (
            none, np.zeros((0, 3)), np.zeros((0, 3, 3)))  # fmt: skip
        self.unseen_facing: tuple[np.ndarray, np.ndarray] = (none, np.zeros(0))
        # The Jacobian's rows, the order that sorts its values into CSR, and its indices
        # and index pointers, made once: every evaluation fills the same structure.
        self._structure: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def hold(self, walls: WallData, known: Mapping[int, tuple[Pose, np.ndarray]],
             seen_facing: Mapping[int, float]) -> None:  # fmt: skip
        """The priors on markers: their walls, the poses already known (with their
        covariances), and the way each marker was seen from (the weak prior on a facing,
        for a marker nothing else says the facing of: `active` picks those)."""
        self.walls = walls
        index = self.marker_index
        ids = sorted(known)
        poses = [(known[i][0].x, known[i][0].y, known[i][0].heading) for i in ids]
        self.known = (
            np.array([index[i] for i in ids], dtype=int),
            np.array(poses, dtype=float).reshape(-1, 3),
            whiteners(np.array([known[i][1] for i in ids]).reshape(-1, 3, 3), "known marker"),
        )
        faced = sorted(seen_facing)
        self.unseen_facing = (np.array([index[i] for i in faced], dtype=int),
                              np.array([seen_facing[i] for i in faced]))  # fmt: skip
        self._structure = None

    # The rows.

    @property
    def rows(self) -> dict[str, slice]:
        """Where each kind of residual lies in the vector."""
        counts = [
            ("start", 3), ("odometry", 3 * len(self.edges.caster)),
            ("casters", len(self.casters.expected)), ("unseen facing", len(self.unseen_facing[0])),
            ("sightings", 3 * len(self.sighting_keyframe)), ("walls", 2 * len(self.walls.marker)),
            ("known", 3 * len(self.known[0])),
        ]  # fmt: skip
        out, at = {}, 0
        for name, count in counts:
            out[name] = slice(at, at + count)
            at += count
        return out

    @property
    def robust_from(self) -> int:
        return self.rows["sightings"].start

    @property
    def robust_blocks(self) -> np.ndarray:
        """For each row from robust_from on, the block it belongs to: its sighting's
        distance and bearing, its facing (pose_graph_solve.outliers says why apart), a
        wall or a known marker, numbered in that order."""
        sightings, walls, known = (len(self.sighting_keyframe), len(self.walls.marker),
                                   len(self.known[0]))  # fmt: skip
        return np.concatenate([2 * np.arange(sightings)[:, None] + [0, 0, 1],
                               2 * sightings + np.arange(walls)[:, None] + [0, 0],
                               2 * sightings + walls + np.arange(known)[:, None] + [0, 0, 0],
                               ], axis=None)  # fmt: skip

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Keyframes (K, 3), casters' turns (C,), markers (M, 3): views of `x`."""
        k3 = 3 * self.keyframes
        return x[:k3].reshape(-1, 3), x[k3 : self.pose_size], x[self.pose_size :].reshape(-1, 3)

    def _column(self, kind: str, index: np.ndarray) -> np.ndarray:
        """The first column of each keyframe, casters' turn or marker in `index`."""
        if kind == "keyframe":
            return 3 * index
        if kind == "caster":
            return 3 * self.keyframes + index
        return self.pose_size + 3 * index

    def evaluate(self, x: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """The residuals, and the Jacobian's values in the order of `_blocks`' structure."""
        parts = [self._start_part(x), self._odometry_part(x), self._caster_part(x),
                 self._unseen_part(x), self._sighting_part(x), self._wall_part(x),
                 self._known_part(x)]  # fmt: skip
        r = np.concatenate([p[0] for p in parts])
        if not jacobian:
            return r, None
        return r, np.concatenate([v.ravel() for p in parts for v in p[1]])

    def residuals(self, x: np.ndarray, active: np.ndarray | None = None) -> np.ndarray:
        r, _ = self.evaluate(x, jacobian=False)
        return r if active is None else r * active

    def jacobian(self, x: np.ndarray, active: np.ndarray | None = None) -> sparse.csr_matrix:
        # Imported at the first solve, not with the module: scipy costs the console's
        # start a quarter of a second, and only a survey solves (issue 26, item 6).
        from scipy import sparse  # type: ignore[import-untyped]

        _, values = self.evaluate(x, jacobian=True)
        assert values is not None
        if self._structure is None:
            rows, cols = self._blocks()
            order = np.lexsort((cols, rows))
            indptr = np.zeros(self.rows["known"].stop + 1, dtype=np.int64)
            np.add.at(indptr, rows + 1, 1)
            self._structure = rows, order, cols[order], np.cumsum(indptr)
        rows, order, indices, indptr = self._structure
        if active is not None:
            values = values * active[rows]
        return sparse.csr_matrix((values[order], indices, indptr),
                                 shape=(self.rows["known"].stop, self.size))  # fmt: skip

    def _blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of every Jacobian value, in `evaluate`'s order: per part, per
        block of columns, row-major within the block."""
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []

        def block(first_row: np.ndarray, height: int, first_col: np.ndarray, width: int) -> None:
            r = first_row[:, None, None] + np.arange(height)[None, :, None]
            c = first_col[:, None, None] + np.arange(width)[None, None, :]
            r, c = np.broadcast_arrays(r, c)
            rows.append(r.ravel())
            cols.append(c.ravel())

        at = self.rows
        block(np.array([0]), 3, np.array([0]), 3)
        edges = np.arange(len(self.edges.caster))
        first = at["odometry"].start + 3 * edges
        block(first, 3, self._column("keyframe", edges), 3)
        block(first, 3, self._column("keyframe", edges + 1), 3)
        with_caster = self.edges.caster >= 0
        block(first[with_caster], 3, self._column("caster", self.edges.caster[with_caster]), 1)
        casters = np.arange(len(self.casters.expected))
        block(at["casters"].start + casters, 1, self._column("caster", casters), 1)
        carried = casters[(casters > 0) & (self.casters.carried > 0)]
        block(at["casters"].start + carried, 1, self._column("caster", carried - 1), 1)
        unseen = self.unseen_facing[0]
        block(at["unseen facing"].start + np.arange(len(unseen)), 1,
              self._column("marker", unseen) + 2, 1)  # fmt: skip
        sightings = np.arange(len(self.sighting_keyframe))
        first = at["sightings"].start + 3 * sightings
        block(first, 3, self._column("keyframe", self.sighting_keyframe), 3)
        block(first, 3, self._column("marker", self.sighting_marker), 3)
        walls = self.walls.marker
        block(at["walls"].start + 2 * np.arange(len(walls)), 2, self._column("marker", walls), 3)
        known = self.known[0]
        block(at["known"].start + 3 * np.arange(len(known)), 3, self._column("marker", known), 3)
        return np.concatenate(rows).astype(np.int64), np.concatenate(cols).astype(np.int64)

    # The parts: each gives its residuals and its Jacobian's blocks, as _blocks lays
    # them out.

    def _start_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        e = x[:3] - self._start
        e[2] = wrap_angles(e[2])
        w = self._start_whiten
        return w @ e, [w]

    def _odometry_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Keyframe k+1 as seen from k, less what the wheels say, with the casters' turn
        released over the edge: the heading turned by release * c, and the travel by
        sway * c (the heading the casters had reached, on average along the way)."""
        edges = self.edges
        kf, casters, _ = self.split(x)
        if not len(edges.caster):
            return np.zeros(0), [np.zeros(0)] * 3
        p0, p1 = kf[:-1], kf[1:]
        cos0, sin0 = np.cos(p0[:, 2]), np.sin(p0[:, 2])
        dx, dy = p1[:, 0] - p0[:, 0], p1[:, 1] - p0[:, 1]
        ahead, left = cos0 * dx + sin0 * dy, -sin0 * dx + cos0 * dy
        c = np.where(edges.caster >= 0, casters[np.maximum(edges.caster, 0)] if len(casters)
                     else 0.0, 0.0)  # fmt: skip
        swayed = edges.sway * c
        cos_s, sin_s = np.cos(swayed), np.sin(swayed)
        tx, ty, turn = edges.motion.T
        px, py = cos_s * tx - sin_s * ty, sin_s * tx + cos_s * ty
        turned = wrap_angles(p1[:, 2] - p0[:, 2] - turn - edges.release * c)
        e = np.stack([ahead - px, left - py, turned], axis=1)
        w = edges.whiten
        zero, one = np.zeros_like(cos0), np.ones_like(cos0)
        d0 = np.stack([np.stack([-cos0, -sin0, left], 1), np.stack([sin0, -cos0, -ahead], 1),
                       np.stack([zero, zero, -one], 1)], 1)  # fmt: skip
        d1 = np.stack([np.stack([cos0, sin0, zero], 1), np.stack([-sin0, cos0, zero], 1),
                       np.stack([zero, zero, one], 1)], 1)  # fmt: skip
        dc = np.stack([edges.sway * py, -edges.sway * px, -edges.release], 1)
        with_caster = edges.caster >= 0
        return np.einsum("eij,ej->ei", w, e).ravel(), [
            w @ d0, w @ d1, np.einsum("eij,ej->ei", w[with_caster], dc[with_caster])]  # fmt: skip

    def _caster_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        _, c, _ = self.split(x)
        prior = self.casters
        before = np.concatenate([[0.0], c[:-1]])
        mean, free = clamped_caster_means(prior, before, self.noise.caster_worst)
        r = (c - mean) / prior.sigma
        carried = (np.arange(len(c)) > 0) & (prior.carried > 0)
        return r, [1 / prior.sigma, (-prior.carried * free / prior.sigma)[carried]]

    def _unseen_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        _, _, m = self.split(x)
        index, facing = self.unseen_facing
        r = wrap_angles(m[index, 2] - facing) / UNSEEN_FACING_SIGMA
        return r, [np.full(len(index), 1 / UNSEEN_FACING_SIGMA)]

    def _sighting_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """What was seen less ekf.PoseFilter.expected's model, per standard deviation:
        distance and bearing from the camera (`camera_forward` ahead of the axle), and
        the facing (the marker's normal in the robot's frame)."""
        kf, _, m = self.split(x)
        p, mk = kf[self.sighting_keyframe], m[self.sighting_marker]
        cos_h, sin_h = np.cos(p[:, 2]), np.sin(p[:, 2])
        f = self.camera_forward
        dx, dy = mk[:, 0] - (p[:, 0] + f * cos_h), mk[:, 1] - (p[:, 1] + f * sin_h)
        q = np.maximum(dx * dx + dy * dy, 1e-12)
        r = np.sqrt(q)
        h = np.stack([r, np.arctan2(dy, dx) - p[:, 2], mk[:, 2] - p[:, 2]], 1)
        e = self.sighting_seen - h
        e[:, 1:] = wrap_angles(e[:, 1:])
        scale = 1 / self.sighting_sigmas
        scale[:, 2] *= self.has_facing
        zero, one = np.zeros_like(r), np.ones_like(r)
        # d(residual) = -scale * d(h): by the robot's pose, then by the marker's.
        dh_robot = np.stack([
            np.stack([-dx / r, -dy / r, f * (dx * sin_h - dy * cos_h) / r], 1),
            np.stack([dy / q, -dx / q, -f * (dy * sin_h + dx * cos_h) / q - 1], 1),
            np.stack([zero, zero, -one], 1)], 1)  # fmt: skip
        dh_marker = np.stack([np.stack([dx / r, dy / r, zero], 1),
                              np.stack([-dy / q, dx / q, zero], 1),
                              np.stack([zero, zero, one], 1)], 1)  # fmt: skip
        scale = scale[:, :, None]
        return (e * scale[:, :, 0]).ravel(), [-scale * dh_robot, -scale * dh_marker]

    def _wall_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        _, _, m = self.split(x)
        walls = self.walls
        mk = m[walls.marker]
        across = np.einsum("wi,wi->w", walls.normal, mk[:, :2] - walls.point)
        facing = wrap_angles(mk[:, 2] - np.arctan2(walls.normal[:, 1], walls.normal[:, 0]))
        r = np.stack([across, facing], 1) / walls.sigma
        jac = np.zeros((len(walls.marker), 2, 3))
        jac[:, 0, :2] = walls.normal / walls.sigma[:, :1]
        jac[:, 1, 2] = 1 / walls.sigma[:, 1]
        return r.ravel(), [jac]

    def _known_part(self, x: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        _, _, m = self.split(x)
        index, prior, w = self.known
        e = m[index] - prior
        e[:, 2] = wrap_angles(e[:, 2])
        return np.einsum("nij,nj->ni", w, e).ravel(), [w]


def prepared(seen: Observation, where: str) -> Observation:
    """A sighting as the graph takes it (ekf.usable: a facing the detector could not
    estimate left out); ValueError, saying `where`, for one without a distance and a
    bearing: a survey's log should never hold one."""
    checked = usable(seen)
    if checked is None:
        raise ValueError(f"{where}: a sighting needs a positive distance and a finite bearing")
    return checked
