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
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from giraff_console.camera.marker_corners import refine_corners
from giraff_console.camera.processors import CameraIntrinsics, Processed

__all__ = [
    "CameraIntrinsics",
    "CameraMount",
    "MarkerDetector",
    "MarkerSighting",
    "Region",
    "refine_corners",
]

# The outline and id, drawn thick enough to survive the terminal view's 8:1 shrink.
MARKER_GREEN = (60, 220, 60)


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the robot: on its centre line, `forward` metres ahead of
    the middle of the wheel axle, pitched down by `pitch` radians (0: level)."""

    forward: float = 0.0
    pitch: float = 0.0


@dataclass(frozen=True)
class Region:
    """Part of a frame to look for markers in: columns `left` to `right` and rows `top`
    to `bottom`, in pixels, the ends excluded."""

    left: int
    top: int
    right: int
    bottom: int

    @property
    def area(self) -> int:
        return max(self.right - self.left, 0) * max(self.bottom - self.top, 0)

    def overlaps(self, other: Region) -> bool:
        return (self.left < other.right and other.left < self.right
                and self.top < other.bottom and other.top < self.bottom)  # fmt: skip

    def around(self, other: Region) -> Region:
        """The least region holding both."""
        return Region(min(self.left, other.left), min(self.top, other.top),
                      max(self.right, other.right), max(self.bottom, other.bottom))  # fmt: skip

    def within(self, width: int, height: int) -> Region:
        """The part of this region inside a frame `width` x `height`."""
        return Region(max(self.left, 0), max(self.top, 0), min(self.right, width),
                      min(self.bottom, height))  # fmt: skip


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
        # The last frame looked through (grey), the intrinsics it was placed with and the
        # regions looked in (None: all of it), and what was found in it; and how often
        # a frame was that one again.
        self._last: tuple[np.ndarray, tuple[object, ...], list[MarkerSighting]] | None = None
        self.repeats = 0
        # A second detector for regions of a frame, whose size limits are set for each
        # region (`_find_in`); the first keeps the whole frame's.
        self._region_detector = cv2.aruco.ArucoDetector(dictionary, detector_parameters())
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

    def detect(self, grey: np.ndarray, frame_time: float = math.nan,
               regions: Sequence[Region] | None = None) -> list[MarkerSighting]:  # fmt: skip
        """The markers in a grey frame, each with its pose from the robot if it can;
        given `regions`, only those in them (`_find_in`)."""
        if not len(self.ids):
            return []
        intrinsics = self.intrinsics(grey.shape[1], grey.shape[0])
        looked = (intrinsics, None if regions is None else tuple(regions))
        last = self._last
        if (
            last is not None and last[1] == looked and last[0].shape == grey.shape
            and np.array_equal(last[0], grey)
        ):  # fmt: skip
            # The very frame looked at last, where it was looked at last (a simulated
            # robot standing still): what it finds is what it found then, at this
            # frame's time (issue 26: a whole frame's search, tens of milliseconds, ten
            # times a second for nothing).
            self.repeats += 1
            return [replace(s, frame_time=frame_time) for s in last[2]]
        found = self._find(grey) if regions is None else self._find_in(grey, regions)
        sightings = []
        for points, index in found:
            refined = refine_corners(grey, points, self.cells)
            points = refined if refined is not None else points
            marker_id = int(self.ids[index])
            sightings.append(self._sighting(marker_id, points, intrinsics, frame_time))
        # A copy: the caller may draw the next frame into the same array.
        self._last = (grey.copy(), looked, sightings)
        return sightings

    def smallest_perimeter(self, width: int, height: int) -> float:
        """The shortest outline, in pixels, of a marker found in a frame `width` x
        `height`: the detector passes over smaller squares."""
        return self.detector.getDetectorParameters().minMarkerPerimeterRate * max(width, height)

    def _find(self, grey: np.ndarray) -> list[tuple[np.ndarray, int]]:
        """The detector's corners, and the index of each marker among its ids."""
        corners, found_ids, _ = self.detector.detectMarkers(grey)
        if found_ids is None:
            return []
        # The stubs type the ids OpenCV finds as any number; they are integers.
        return [(found.reshape(4, 2).astype(np.float64), int(index))
                for found, index in zip(corners, found_ids.ravel(), strict=True)]  # fmt: skip

    def _find_in(self, grey: np.ndarray, regions: Sequence[Region]) -> list[tuple[np.ndarray, int]]:
        """`_find` in each of `regions` of the frame, corners in the frame's pixels.

        A marker is found in a region as in the whole frame when the region reaches a
        little beyond it (the thresholding windows, 23 pixels at most, must see what the
        whole frame has round its square): the caller's regions do. The detector's
        least and greatest outline are fractions of the longer side of the image it is
        given, so for a region they are set to stay the whole frame's in pixels (OpenCV
        truncates them to whole pixels, hence the half pixel)."""
        height, width = grey.shape
        whole = self.detector.getDetectorParameters()
        shortest = int(whole.minMarkerPerimeterRate * max(width, height)) + 0.5
        longest = int(whole.maxMarkerPerimeterRate * max(width, height)) + 0.5
        parameters = detector_parameters()
        found: list[tuple[np.ndarray, int]] = []
        for region in regions:
            region = region.within(width, height)
            if not region.area:
                continue
            crop = grey[region.top : region.bottom, region.left : region.right]
            side = max(crop.shape)
            parameters.minMarkerPerimeterRate = shortest / side
            parameters.maxMarkerPerimeterRate = longest / side
            self._region_detector.setDetectorParameters(parameters)
            corners, found_ids, _ = self._region_detector.detectMarkers(crop)
            if found_ids is None:
                continue
            offset = np.array([region.left, region.top], dtype=np.float64)
            for corner, index in zip(corners, found_ids.ravel(), strict=True):
                if all(int(index) != other for _, other in found):  # once, if regions overlap
                    found.append((corner.reshape(4, 2) + offset, int(index)))
        return found

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
        data = _sightings_data(sightings)
        if not sightings:
            return Processed(image, data)
        return Processed(draw_sightings(image, sightings), data)

    def find(self, grey: np.ndarray, captured_at: float) -> dict[str, object]:
        return _sightings_data(self.detect(grey, captured_at))


def _sightings_data(sightings: list[MarkerSighting]) -> dict[str, object]:
    return {"markers": sightings, "marker_ids": [s.id for s in sightings]}


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
