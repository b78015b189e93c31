"""Fiducial markers on the walls: found in the frame, and where each is from the robot.

The thesis's navigation system (Figure 2.1) starts with feature extraction; §2.3.1 says
why dead reckoning alone drifts, and §5.4 and §6 expect the camera to correct it. This
processor finds the markers the floor plan puts on the walls (AprilTag 36h11 by
default, through OpenCV's cv2.aruco) and estimates each one's pose relative to the
camera with solvePnP (IPPE_SQUARE, made for a square's four corners, with SQPNP beside
it), using the camera's intrinsics. It runs in the camera's thread like FAST and Canny.

Intrinsics: the synthetic camera's are exact (sim/camera.py, `WorldCamera.intrinsics`).
A real camera's come from `--calibration`; the pipeline undistorts every frame before
any processor runs, with the calibration's own camera matrix as the new one, so the
intrinsics that apply to the frames here are that matrix scaled to the frame's size
with no distortion left (`Undistortion.intrinsics`). Without either, markers are still
outlined with their ids, but no distance or bearing is claimed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from giraff_console.camera.processors import CameraIntrinsics, Processed

__all__ = ["CameraIntrinsics", "CameraMount", "MarkerDetector", "MarkerSighting"]

# The outline and id, drawn thick enough to survive the terminal view's 8:1 shrink.
MARKER_GREEN = (60, 220, 60)


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the robot: on its centre line, `forward` metres ahead of
    the middle of the wheel axle, pitched down by `pitch` radians (0: level)."""

    forward: float = 0.0
    pitch: float = 0.0


@dataclass(frozen=True, eq=False)  # eq would compare the corners' arrays: ambiguous
class MarkerSighting:
    """One marker seen in one frame.

    `corners` are its black square's four corners in pixels (top left, top right,
    bottom right, bottom left of the printed marker), as the detector refined them.
    `distance_m` is from the middle of the robot's wheel axle to the marker's centre
    along the floor; `bearing_rad` the marker's direction from the robot's heading,
    positive to the left; `facing_rad` the way the marker's face looks (its normal) in
    the robot's frame, so pi for a marker straight ahead that faces the robot. The three
    are NaN when the camera's intrinsics are unknown. `frame_time` is when the frame was
    captured, by the camera source's clock. `reprojection_px` is the corners' RMS distance from the
    estimated pose's projection: a sighting that fits badly is suspect."""

    id: int
    corners: np.ndarray
    distance_m: float
    bearing_rad: float
    facing_rad: float
    frame_time: float
    reprojection_px: float = math.nan


def aruco_dictionary(family: str) -> cv2.aruco.Dictionary:
    """The cv2.aruco predefined dictionary for a family named as the floor plan names it:
    lower case without DICT_ (`apriltag_36h11`, `4x4_50`). ValueError if unknown."""
    names = {name.removeprefix("DICT_").lower(): name for name in dir(cv2.aruco)
             if name.startswith("DICT_")}  # fmt: skip
    name = names.get(family.lower())
    if name is None:
        raise ValueError(f"unknown marker family {family!r}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


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
    dimensions (what an SVD gives)."""
    points = np.where(taken[..., None], points, 0.0)
    middle = points.sum(axis=1) / taken.sum(axis=1)[:, None]
    x, y = np.moveaxis(np.where(taken[..., None], points - middle[:, None], 0.0), 2, 0)
    angle = 0.5 * np.arctan2(2 * (x * y).sum(axis=1), (x * x - y * y).sum(axis=1))
    return middle, np.stack([np.cos(angle), np.sin(angle)], axis=1)


def _median(values: np.ndarray) -> float:
    """np.median's result for a few values, without its overhead."""
    ordered = np.sort(values)
    n = len(ordered)
    return float((ordered[(n - 1) // 2] + ordered[n // 2]) / 2)


def detector_parameters() -> cv2.aruco.DetectorParameters:
    """The detector's settings: its defaults, but for two that cost time and find nothing
    more here (bench/camera.py, docs/performance.md). `refine_corners` then places the
    corners."""
    parameters = cv2.aruco.DetectorParameters()
    # Thresholding windows of 3 and 23 pixels, not 3, 13 and 23: a third of the work,
    # and as many markers found out to 3 m (the 13-pixel pass found a rare one at 3.5).
    parameters.adaptiveThreshWinSizeStep = 20
    # No candidate under 10 pixels a side (5 % of the longer image side round it): a
    # 16 cm marker that small is over 6 m off, beyond where one is decoded at all; the
    # floor's tiles and the posters' squares below that size are not looked at.
    parameters.minMarkerPerimeterRate = 0.05
    return parameters


class MarkerDetector:
    """Finds markers of `family`, each `size` metres across its black square, and turns
    their corners into `MarkerSighting`s.

    `intrinsics(width, height)` gives the camera's intrinsics at a frame's size, or None
    when they are not known. The sightings of each frame are in the data under
    "markers"; the ids under "marker_ids".

    `ids`, when given (the floor plan's markers), are the only ones looked for: others of
    the family are not reported. OpenCV 5 decodes a candidate square by comparing its
    cells with every marker the detector knows, all 587 of AprilTag 36h11 otherwise, and
    a building's posters and tiles make a dozen candidates a frame: with the example
    care home's 172 the decoding costs a third as much (docs/performance.md, issue 14).
    AprilTag 36h11's markers differ in at least 11 of their 36 bits, so leaving the others
    out lets no misread one pass for a plan's: the error correction is the family's."""

    name = "markers"

    def __init__(
        self,
        family: str,
        size: float,
        intrinsics: Callable[[int, int], CameraIntrinsics | None] | None = None,
        mount: CameraMount | None = None,
        ids: Iterable[int] | None = None,
    ) -> None:
        if not (size > 0 and math.isfinite(size)):
            raise ValueError("the markers' size must be positive")
        self.family = family
        self.size = size
        self.intrinsics = intrinsics or (lambda width, height: None)
        self.mount = mount or CameraMount()
        dictionary = aruco_dictionary(family)
        self.cells = int(dictionary.markerSize) + 2
        # The id of each of the detector's markers, by its index there.
        self.ids = np.arange(len(dictionary.bytesList))
        if ids is not None:
            wanted = np.array(sorted(set(ids)), dtype=int)
            if len(wanted) and (wanted[0] < 0 or wanted[-1] >= len(self.ids)):
                raise ValueError(f"{family} has markers 0 to {len(self.ids) - 1} only")
            self.ids = wanted
            if len(wanted):  # none wanted: `detect` finds none without looking
                dictionary = cv2.aruco.Dictionary(
                    dictionary.bytesList[wanted], dictionary.markerSize,
                    dictionary.maxCorrectionBits,
                )  # fmt: skip
        self.detector = cv2.aruco.ArucoDetector(dictionary, detector_parameters())
        half = size / 2
        # The order IPPE_SQUARE wants, which is also the order the detector gives.
        self.square = np.array(
            [[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]],
            dtype=np.float64,
        )
        pitch = self.mount.pitch
        # Camera axes (x right, y down, z ahead) in the robot's (x ahead, y left, z up),
        # as columns; the camera pitched down by `pitch` about the robot's y axis.
        self.to_robot = np.array(
            [
                [0.0, -math.sin(pitch), math.cos(pitch)],
                [-1.0, 0.0, 0.0],
                [0.0, -math.cos(pitch), -math.sin(pitch)],
            ]
        )

    def detect(self, grey: np.ndarray, frame_time: float = math.nan) -> list[MarkerSighting]:
        """The markers in a grey frame, each with its pose from the robot if it can."""
        if not len(self.ids):
            return []
        corners, found_ids, _ = self.detector.detectMarkers(grey)
        if found_ids is None:
            return []
        intrinsics = self.intrinsics(grey.shape[1], grey.shape[0])
        sightings = []
        for found, index in zip(corners, found_ids.ravel(), strict=True):
            points = found.reshape(4, 2).astype(np.float64)
            refined = refine_corners(grey, points, self.cells)
            points = refined if refined is not None else points
            # The stubs type the ids OpenCV finds as any number; they are integers.
            marker_id = int(self.ids[int(index)])
            sightings.append(self._sighting(marker_id, points, intrinsics, frame_time))
        return sightings

    def _sighting(
        self, marker_id: int, points: np.ndarray, intrinsics: CameraIntrinsics | None,
        frame_time: float,
    ) -> MarkerSighting:  # fmt: skip
        if intrinsics is None:
            return MarkerSighting(marker_id, points, math.nan, math.nan, math.nan, frame_time)
        pose = self._pose(points, intrinsics)
        if pose is None:
            return MarkerSighting(marker_id, points, math.nan, math.nan, math.nan, frame_time)
        rotation, translation, error = pose
        centre = self.to_robot @ translation.ravel() + [self.mount.forward, 0.0, 0.0]
        # The marker's normal, out of its face: the z axis of its square's frame.
        normal = self.to_robot @ cv2.Rodrigues(rotation)[0][:, 2]
        return MarkerSighting(
            marker_id,
            points,
            float(math.hypot(centre[0], centre[1])),
            float(math.atan2(centre[1], centre[0])),
            float(math.atan2(normal[1], normal[0])),
            frame_time,
            error,
        )

    def _pose(self, points: np.ndarray, intrinsics: CameraIntrinsics):
        """The square's rotation and translation from the camera, and the corners' RMS
        reprojection error in pixels; None if no solver found one.

        IPPE_SQUARE gives both poses a square's four corners allow (a small square far
        off can look the same tilted either way); SQPNP stands beside it because
        OpenCV's IPPE breaks down on a square seen exactly face-on (pixels of
        reprojection error), which the simulator shows whenever the robot squares up to
        a wall. The pose that fits the corners best wins."""
        matrix = intrinsics.matrix()
        distortion = np.array(intrinsics.distortion, dtype=np.float64)
        best = None
        for method in (cv2.SOLVEPNP_IPPE_SQUARE, cv2.SOLVEPNP_SQPNP):
            try:
                count, rotations, translations, _ = cv2.solvePnPGeneric(
                    self.square, points, matrix, distortion, flags=method
                )
            except cv2.error:
                continue
            for rotation, translation in zip(rotations[:count], translations[:count], strict=True):
                if translation[2, 0] <= 0:
                    continue  # behind the camera: no marker is seen from there
                projected, _ = cv2.projectPoints(
                    self.square, rotation, translation, matrix, distortion
                )
                error = float(np.sqrt(np.mean(np.sum((projected.reshape(4, 2) - points) ** 2, 1))))
                if best is None or error < best[2]:
                    best = (rotation, translation, error)
        return best

    def process(self, image: np.ndarray, grey: np.ndarray, captured_at: float) -> Processed:
        sightings = self.detect(grey, captured_at)
        data = {"markers": sightings, "marker_ids": [s.id for s in sightings]}
        if not sightings:
            return Processed(image, data)
        return Processed(draw_sightings(image, sightings), data)


def draw_sightings(image: np.ndarray, sightings: list[MarkerSighting]) -> np.ndarray:
    """A copy of `image` with each marker outlined and its id beside it, in green."""
    shown = image.copy()
    height, width = image.shape[:2]
    # The terminal view shrinks an 800-pixel frame to about 100 columns: lines of a few
    # pixels would vanish into their neighbours, so they scale with the frame.
    thickness = max(2, round(width / 160))
    scale = max(0.5, height / 300)
    for sighting in sightings:
        corners = np.round(sighting.corners).astype(np.int32)
        cv2.polylines(shown, [corners], True, MARKER_GREEN, thickness, cv2.LINE_AA)
        label = str(sighting.id)
        text_thickness = max(1, round(scale * 2))
        (text_width, text_height), base = cv2.getTextSize(
            label, cv2.FONT_HERSHEY_SIMPLEX, scale, text_thickness
        )
        # Above the marker if there is room, else below it.
        x = int(np.clip(corners[:, 0].min(), 0, max(0, width - text_width)))
        top = int(corners[:, 1].min()) - thickness - 2
        y = top if top - text_height - base >= 0 else int(corners[:, 1].max()) + text_height + 2
        y = min(y, height - base)
        cv2.rectangle(shown, (x - 2, y - text_height - 2), (x + text_width + 2, y + base),
                      (0, 0, 0), -1)  # fmt: skip
        cv2.putText(shown, label, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, MARKER_GREEN,
                    text_thickness, cv2.LINE_AA)  # fmt: skip
    return shown
