"""A marker's corners to a few hundredths of a pixel, from the grey levels across its
black square's sides (camera/markers.py, issue 14).

The detector's own corners are good to about half a pixel; a third of a pixel on a
20-pixel marker three metres off is 5 cm, so each side is found again as AprilTag does.
"""

from __future__ import annotations

import cv2
import numpy as np

# The black square's sides are sampled between these fractions of their length, clear of
# the corners, where the other sides' edges would bend the profiles.
SIDE_SPAN = (0.15, 0.85)
# Profile samples across an edge, pixels apart.
PROFILE_STEP_PX = 0.1
# An edge point farther than this from its side's line is noise or a neighbour's edge.
OUTLIER_PX = 0.5


def refine_corners(grey: np.ndarray, corners: np.ndarray, cells: int) -> np.ndarray | None:
    """The black square's corners to a few hundredths of a pixel, or None.

    The detector's own corners are good to about half a pixel (its contours run along
    the dark pixels' centres, half a pixel inside the edge), and OpenCV's sub-pixel
    refinement to about a third with cells a few pixels wide; a third of a pixel on a
    20-pixel marker three metres off is 5 cm. So each side is found again, as AprilTag
    does: where the grey level across the edge crosses half-way between the ink's and
    the paper's, at points along the side, a straight line fitted through them, and the
    corners where neighbouring lines cross. `cells` is the cells along a side, border
    included (8 for AprilTag 36h11)."""
    corners = corners.astype(np.float64)
    following = np.roll(corners, -1, axis=0)
    sides = np.linalg.norm(following - corners, axis=1)
    if sides.min() < 4:
        return None
    # Across each side a cell is as wide as the neighbouring sides' cells are long.
    cell = (np.roll(sides, 1) + np.roll(sides, -1)) / 2 / cells
    lines = _sides(grey, corners, following, corners.mean(axis=0), cell, _ink(grey, corners))
    if lines is None:
        return None
    # Each corner where the side before it crosses the side after it.
    p, d = np.roll(lines[0], 1, axis=0), np.roll(lines[1], 1, axis=0)
    q, e = lines
    determinant = e[:, 0] * d[:, 1] - d[:, 0] * e[:, 1]
    if np.abs(determinant).min() < 1e-6:
        return None
    gap = q - p
    refined = p + ((e[:, 0] * gap[:, 1] - gap[:, 0] * e[:, 1]) / determinant)[:, None] * d
    # A corner that moved more than a cell is not the same corner.
    if np.max(np.linalg.norm(refined - corners, axis=1)) > max(2.0, sides.min() / cells):
        return None
    return refined


def _ink(grey: np.ndarray, corners: np.ndarray) -> float:
    """The ink's grey level: the darkest of the square's inside (a low percentile, so
    that one noisy pixel does not set it)."""
    x0, y0 = np.maximum(np.floor(corners.min(axis=0)).astype(int), 0)
    x1, y1 = np.ceil(corners.max(axis=0)).astype(int) + 1
    box = grey[y0:y1, x0:x1]
    mask = np.zeros(box.shape, dtype=np.uint8)
    cv2.fillConvexPoly(mask, np.round(corners - [x0, y0]).astype(np.int32), 1)
    inside = np.sort(box[mask.astype(bool)]).astype(np.float64)
    if not inside.size:
        return 0.0
    # The 2nd percentile as np.percentile has it (between the two nearest, linearly),
    # without its overhead, which is most of this function's.
    at = 0.02 * (len(inside) - 1)
    low = int(at)
    high = min(low + 1, len(inside) - 1)
    return float(inside[low] + (inside[high] - inside[low]) * (at - low))


def _sides(grey, a, b, centre, cell, ink, passes=2):
    """The lines (points and unit directions, a row a side) along which the ink meets
    the paper on the sides from corners a to corners b: where each profile across a
    side first rises through half-way. None if a side has none.

    The four sides are measured together, each with its own samples, padded to the
    longest side's and masked: numpy's overhead is paid once a pass, not once a side."""
    step = PROFILE_STEP_PX
    reach = np.maximum(1.5, 1.2 * cell)
    # np.arange(-reach, reach + step / 2, step) for each side, padded to the widest: the
    # same samples (numpy steps by (start + step) - start, a hair off `step`).
    start = -reach
    widths = np.ceil((reach + step / 2 - start) / step).astype(int)
    across = np.arange(widths.max())
    offsets = start[:, None] + across * ((start + step) - start)[:, None]
    within = across < widths[:, None]  # (sides, offsets)
    line = None
    for _ in range(passes):
        length = np.linalg.norm(b - a, axis=1)
        along = (b - a) / length[:, None]
        outward = np.stack([along[:, 1], -along[:, 0]], axis=1)
        outward[np.einsum("sk,sk->s", outward, centre - a) > 0] *= -1
        counts = np.minimum(np.maximum(length / 2, 6), 32).astype(int)
        # np.linspace(*SIDE_SPAN, count) for each side, to the same count.
        rows = np.arange(counts.max())
        first, last = SIDE_SPAN
        at = rows * ((last - first) / (counts - 1))[:, None] + first
        at[np.arange(len(counts)), counts - 1] = last
        at *= length[:, None]
        used = rows < counts[:, None]  # (sides, points)
        # Where each profile's samples are: (sides, points, offsets), x then y.
        x, y = (a[:, k, None, None] + at[..., None] * along[:, k, None, None]
                + offsets[:, None, :] * outward[:, k, None, None] for k in (0, 1))  # fmt: skip
        profiles = cv2.remap(
            grey, x.reshape(-1, len(across)).astype(np.float32),
            y.reshape(-1, len(across)).astype(np.float32), cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REPLICATE,
        ).reshape(x.shape).astype(np.float64)  # fmt: skip
        # The paper: the brightest just outside, within the quiet zone.
        outside = (within & (offsets > 0))[:, None]
        brightest = np.where(outside, profiles, -np.inf).max(axis=2)
        paper = np.array([_median(side[:n]) for side, n in zip(brightest, counts, strict=True)])
        if (paper - ink < 30).any():
            return None
        level = (ink + paper) / 2
        above = profiles >= level[:, None, None]
        rising = ~above[..., :-1] & above[..., 1:] & within[:, None, 1:] & used[..., None]
        crossed = rising.any(axis=2)  # (sides, points)
        if crossed.sum(axis=1).min() < 4:
            return None
        # On each profile, the rise nearest the side as it stands: the ink-to-paper edge
        # itself (the first of two as near).
        j = np.where(rising, np.abs(offsets[:, None, :-1]), np.inf).argmin(axis=2)
        low = np.take_along_axis(profiles, j[..., None], axis=2)[..., 0]
        high = np.take_along_axis(profiles, j[..., None] + 1, axis=2)[..., 0]
        with np.errstate(divide="ignore", invalid="ignore"):  # profiles that never rise
            s = (level[:, None] - low) / (high - low) * step
        s = np.where(crossed, s + np.take_along_axis(offsets, j, axis=1), 0.0)
        edge = a[:, None] + at[..., None] * along[:, None] + s[..., None] * outward[:, None]
        point, direction = _fit(edge, crossed)
        normal = np.stack([direction[:, 1], -direction[:, 0]], axis=1)
        distance = np.abs(np.einsum("spk,sk->sp", edge - point[:, None], normal))
        near = crossed & (distance <= OUTLIER_PX)
        again = (crossed & ~near).any(axis=1) & (near.sum(axis=1) >= 4)
        if again.any():
            refit = _fit(edge, near)
            point[again], direction[again] = refit[0][again], refit[1][again]
        direction[np.einsum("sk,sk->s", direction, along) < 0] *= -1
        a = point + np.einsum("sk,sk->s", a - point, direction)[:, None] * direction
        b = point + np.einsum("sk,sk->s", b - point, direction)[:, None] * direction
        line = (point, direction)
    return line


def _fit(points: np.ndarray, taken: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each row of `points`, the straight line nearest those `taken` (total least
    squares): a point and a unit direction, a row each.

    The direction is the principal axis of the points' scatter, in closed form for two
    dimensions (what an SVD gives). A row with none taken (a refit asks for every side,
    and uses only those it needs) gets a line through the origin."""
    points = np.where(taken[..., None], points, 0.0)
    middle = points.sum(axis=1) / np.maximum(taken.sum(axis=1), 1)[:, None]
    x, y = np.moveaxis(np.where(taken[..., None], points - middle[:, None], 0.0), 2, 0)
    angle = 0.5 * np.arctan2(2 * (x * y).sum(axis=1), (x * x - y * y).sum(axis=1))
    return middle, np.stack([np.cos(angle), np.sin(angle)], axis=1)


def _median(values: np.ndarray) -> float:
    """np.median's result for a few values, without its overhead."""
    ordered = np.sort(values)
    n = len(ordered)
    return float((ordered[(n - 1) // 2] + ordered[n // 2]) / 2)
