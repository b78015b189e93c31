"""Where a range scan fits the map built so far: a correlative scan matcher (issue 29).

Odometry drifts (§2.3: wheel distance errors, and the casters turning the robot after a
turn on the spot), and a map drawn at drifting poses smears every wall into a fan. The
markers correct the pose filter now and then (§2.6.3); between them the scan itself can
say where the robot stands, because its walls must fall on the walls already drawn.

The matcher tries poses on a lattice around the filter's pose and scores each by how
near its hits fall to occupied cells: a likelihood field, each cell's value
exp(-d^2 / 2 sigma^2) for its distance d to the nearest occupied cell (one distance
transform per scan). A coarse lattice on a blurred field finds the basin; a fine one on a
sharp field around its best finds the pose. The search is exhaustive within its reach,
so it cannot be trapped by a local optimum as an iterative matcher can, and its cost is
known in advance (the lattice sizes below).

A scan pins the pose only in the directions its walls face. In a corridor every wall
runs along it, so the scan fits anywhere along the corridor equally well: the pose is
then matched in heading and across the corridor only, and along it the filter's pose is
kept (`ACROSS_ONLY`). A scan with too little of anything is not matched at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import cv2
import numpy as np

from giraff_console.robot.odometry import Pose

# The coarse lattice: +-COARSE_REACH_M in steps of COARSE_STEP_M each way, and
# +-COARSE_TURN in steps of COARSE_TURN_STEP: 7 x 7 x 9 = 441 poses. The reach is far
# more than the pose drifts between two scans (at 5.5 scans/s and 0.4 m/s the robot
# moves 7 cm: 1.5 mm of it at 2 %, 0.1 degree at 1.5 degrees a metre), so that a jump of
# the filter's pose (a marker's correction) or a drift kept along a corridor is found.
COARSE_REACH_M, COARSE_STEP_M = 0.30, 0.10
COARSE_TURN, COARSE_TURN_STEP = math.radians(4.0), math.radians(1.0)
# The most the coarse lattice is widened in heading, when the filter says the heading
# may have moved more than COARSE_TURN since the last scan: the casters turn the robot
# by up to 45 degrees as it sets off after a turn on the spot (§3.2.1.5), unseen by the
# wheels, over the first few scans of its way.
MAX_COARSE_TURN = math.radians(30.0)
# The fine lattice round the coarse best: 5 x 5 x 7 = 175 poses.
FINE_REACH_M, FINE_STEP_M = 0.05, 0.025
FINE_TURN, FINE_TURN_STEP = math.radians(0.75), math.radians(0.25)
# The fields' widths: the coarse one wide enough that a hit a coarse step away from its
# wall still scores, the fine one about a cell and the scan's noise.
COARSE_SIGMA_M, FINE_SIGMA_M = 0.10, 0.05
# A scan with fewer hits than this says too little to be matched.
MIN_HITS = 40
# The most hits a scan is matched with (an A2's densest turn has 1600; 800 fix a pose).
MAX_MATCHED_HITS = 800
# The occupied cells the map must have round the scan to match against (2.5 m of wall).
MIN_MAP_CELLS = 50
# The metres of wall facing a direction that pin the pose along it.
MIN_PINNING_M = 1.0
# The hits are merged into pieces of surface this long before their normals are taken.
PIECE_M = 0.1
# Two neighbouring hits belong to one surface when they are at most this far apart, or
# this many beam spacings at their range.
SURFACE_GAP_M, SURFACE_GAP_BEAMS = 0.25, 3.0
# The match replaces the filter's pose only when its hits' mean likelihood is at least
# MIN_QUALITY (most hits on a drawn wall: a fit, not a coincidence) and above the filter
# pose's. Asking for a margin above it as well was measured worse while this was tuned:
# on the care-home wing's drive (tests/mapping), a margin of 0.005 let the drift grow
# until it cleared it, and the worst pose error went from 7 to 9 cm.
MIN_QUALITY = 0.35


class MatchOutcome(Enum):
    """What the matcher made of one scan."""

    MATCHED = "matched"  # the pose the scan fits best was used
    ACROSS_ONLY = "across only"  # a corridor: heading and across matched, along kept
    FILTER_KEPT = "filter kept"  # the fit was not clearly better than the filter's pose
    FEATURELESS = "featureless"  # the scan's walls pin no direction
    TOO_FEW_HITS = "too few hits"
    MAP_TOO_SPARSE = "map too sparse"  # too little drawn yet round the scan
    MATCHING_OFF = "matching off"


# The outcomes in which the matched pose, not the filter's, was used.
USED = frozenset({MatchOutcome.MATCHED, MatchOutcome.ACROSS_ONLY})


@dataclass(frozen=True)
class Match:
    outcome: MatchOutcome
    pose: Pose  # the pose to draw the scan at
    quality: float  # the mean likelihood of the hits at that pose, 0 to 1
    # ACROSS_ONLY: the unit direction (map frame) along which the scan fits anywhere.
    along: tuple[float, float] | None = None


@dataclass(frozen=True)
class LikelihoodField:
    """A window of the map as the matcher scores it: `fine` and `coarse` fields over
    the same cells, whose top-left corner is at map (left, top)."""

    fine: np.ndarray
    coarse: np.ndarray
    left: float
    top: float
    resolution: float


def likelihood_field(
    occupied: np.ndarray, left: float, top: float, resolution: float
) -> LikelihoodField:
    """The fields of a window of the map whose occupied cells are `occupied`."""
    distance = cv2.distanceTransform((~occupied).astype(np.uint8), cv2.DIST_L2, 5)
    squared = np.square(distance * np.float32(resolution))
    fine = np.exp(squared * np.float32(-0.5 / FINE_SIGMA_M**2))
    coarse = np.exp(squared * np.float32(-0.5 / COARSE_SIGMA_M**2))
    for values in (fine, coarse):  # the border scores nothing (_scores clips onto it)
        values[[0, -1], :] = 0
        values[:, [0, -1]] = 0
    return LikelihoodField(fine, coarse, left, top, resolution)


@dataclass(frozen=True)
class Pinning:
    """How firmly a scan's walls pin each direction (in the robot's frame): `weak` is
    the unit direction they pin least, `least` and `most` the metres of wall whose
    normals lie along it and across it."""

    weak: tuple[float, float]
    least: float
    most: float


def pinning(points: np.ndarray, spacing: float) -> Pinning:
    """The pinning of a scan's hits, `points` (N, 2) in the robot's frame in bearing
    order, `spacing` the angle between beams. The hits are first merged into pieces of
    surface PIECE_M long, so that the range noise of hits a centimetre apart (a wall
    close by) does not turn their joins every way; then each piece's normal n, weighted
    by its length, is summed as n n^T, whose eigenvectors say which directions the
    walls face."""
    if len(points) < 2:
        return Pinning((1.0, 0.0), 0.0, 0.0)
    step = np.hypot(*np.diff(points, axis=0).T)
    reach = np.hypot(points[1:, 0], points[1:, 1])
    joined = (step <= SURFACE_GAP_M) | (step <= SURFACE_GAP_BEAMS * spacing * reach)
    # Along each surface, the distance walked; a gap starts a new piece.
    walked = np.concatenate([[0.0], np.cumsum(np.where(joined, step, 0.0))])
    surface = np.concatenate([[0], np.cumsum(~joined)])
    _, piece = np.unique(np.column_stack([surface, np.floor(walked / PIECE_M)]), axis=0,
                         return_inverse=True)  # fmt: skip
    piece = piece.ravel()
    count = np.bincount(piece)
    centres = np.column_stack([np.bincount(piece, points[:, 0]),
                               np.bincount(piece, points[:, 1])]) / count[:, None]  # fmt: skip
    first = np.unique(piece, return_index=True)[1]
    same = np.diff(surface[first]) == 0
    chord = np.diff(centres, axis=0)[same]
    length = np.hypot(chord[:, 0], chord[:, 1])
    chord, length = chord[length > 0], length[length > 0]
    # n n^T = I - t t^T for a unit normal n perpendicular to the unit tangent t; with t
    # = chord / length, each piece's length * (I - t t^T) is below.
    normals = length.sum() * np.eye(2) - (chord.T @ (chord / length[:, None]))
    values, vectors = np.linalg.eigh(normals)
    return Pinning((float(vectors[0, 0]), float(vectors[1, 0])), float(values[0]),
                   float(values[1]))  # fmt: skip


def match(field: LikelihoodField, prior: Pose, points: np.ndarray, spacing: float,
          turn_reach: float = COARSE_TURN) -> Match:  # fmt: skip
    """The pose near `prior` (within the coarse lattice, and `turn_reach` radians
    either way) at which the hits `points` (N, 2, robot frame, metres, in bearing order)
    fit `field` best, if the scan pins it and the fit is clearly better than `prior`'s;
    otherwise `prior`, and why."""
    if len(points) < MIN_HITS:
        return Match(MatchOutcome.TOO_FEW_HITS, prior, 0.0)
    if len(points) > MAX_MATCHED_HITS:
        # Thinned evenly: the lattice holds an index per hit and candidate pose, 8 bytes
        # each, 200 MB for 8192 hits at its widest turn.
        step = math.ceil(len(points) / MAX_MATCHED_HITS)
        points, spacing = points[::step], spacing * step
    pins = pinning(points, spacing)
    if pins.most < MIN_PINNING_M:
        return Match(MatchOutcome.FEATURELESS, prior, 0.0)
    before = _scores(field.fine, field, prior, points, np.zeros(1), np.zeros(1))[0, 0]
    steps = _steps(COARSE_REACH_M, COARSE_STEP_M)
    coarse = _lattice(steps)
    turns = _steps(min(max(turn_reach, COARSE_TURN), MAX_COARSE_TURN), COARSE_TURN_STEP)
    scores = _scores(field.coarse, field, prior, points, turns, steps)
    turn, shift = np.unravel_index(int(np.argmax(scores)), scores.shape)
    centre = _moved(prior, coarse[shift], float(turns[turn]))
    steps = _steps(FINE_REACH_M, FINE_STEP_M)
    fine = _lattice(steps)
    turns = _steps(FINE_TURN, FINE_TURN_STEP)
    scores = _scores(field.fine, field, centre, points, turns, steps)
    turn, shift = np.unravel_index(int(np.argmax(scores)), scores.shape)
    best = _moved(centre, fine[shift], float(turns[turn]))
    quality = float(scores[turn, shift]) / len(points)
    if quality < MIN_QUALITY or quality <= before / len(points):
        return Match(MatchOutcome.FILTER_KEPT, prior, before / len(points))
    if pins.least >= MIN_PINNING_M:
        return Match(MatchOutcome.MATCHED, best, quality)
    # Along the weak direction every shift fits alike: keep the filter's position there.
    c, s = math.cos(best.heading), math.sin(best.heading)
    wx, wy = c * pins.weak[0] - s * pins.weak[1], s * pins.weak[0] + c * pins.weak[1]
    along = (best.x - prior.x) * wx + (best.y - prior.y) * wy
    return Match(MatchOutcome.ACROSS_ONLY,
                 Pose(best.x - along * wx, best.y - along * wy, best.heading), quality,
                 (wx, wy))  # fmt: skip


def _steps(reach: float, step: float) -> np.ndarray:
    count = round(reach / step)
    return np.arange(-count, count + 1) * step


def _lattice(steps: np.ndarray) -> np.ndarray:
    """The (dx, dy) shifts of the square lattice of `steps` each way, (S * S, 2), dx
    changing fastest."""
    dx, dy = np.meshgrid(steps, steps)
    return np.column_stack([dx.ravel(), dy.ravel()])


def _moved(pose: Pose, shift: np.ndarray, turn: float) -> Pose:
    return Pose(pose.x + float(shift[0]), pose.y + float(shift[1]), pose.heading + turn)


def _scores(
    values: np.ndarray,
    field: LikelihoodField,
    centre: Pose,
    points: np.ndarray,
    turns: np.ndarray,
    steps: np.ndarray,
) -> np.ndarray:
    """The summed field under the hits for each turn of `centre` and each shift of the
    square lattice of `steps` (as `_lattice` orders them), (T, S * S): every candidate
    pose at once. A shift moves a hit's column and row independently, so they are found
    for each step along x and along y, (T, N, S) each, and only their sum is taken for
    the whole lattice, as one gather of T x N x S^2 cells."""
    headings = centre.heading + turns
    c, s = np.cos(headings)[:, None], np.sin(headings)[:, None]
    x = centre.x + c * points[:, 0] - s * points[:, 1]  # (T, N)
    y = centre.y + s * points[:, 0] + c * points[:, 1]
    inverse = 1.0 / field.resolution
    height, width = values.shape
    # A hit off the window is clipped onto its border, whose cells score nothing.
    cols = np.floor((x[:, :, None] + steps - field.left) * inverse).astype(np.intp)
    rows = np.floor((field.top - y[:, :, None] - steps) * inverse).astype(np.intp)
    np.clip(cols, 0, width - 1, out=cols)
    np.clip(rows, 0, height - 1, out=rows)
    cells = (rows * width)[:, :, :, None] + cols[:, :, None, :]  # (T, N, S, S)
    gathered = np.take(values, cells)
    return gathered.sum(axis=1).reshape(len(turns), -1)
