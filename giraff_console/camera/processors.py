"""Frame processors as plug-ins: a frame goes in, an overlay and data come out (§3.6, B.9)."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, cast

import cv2
import numpy as np

from giraff_console.camera.defaults import FAST_THRESHOLD
from giraff_console.file_limits import FileRefused, read_bounded
from giraff_console.yaml_source import YamlSourceError, parse_yaml

# FAST's pink in the thesis (B.9): BGR (128, 0, 255); its threshold is in defaults.py.
PINK = (128, 0, 255)
# The Canny thresholds of the thesis's demonstration (B.9, Figure 5.1).
CANNY_LOW, CANNY_HIGH = 20, 50


@dataclass
class Processed:
    """What a processor made of a frame: the image to show, and what it found."""

    image: np.ndarray
    data: dict[str, object] = field(default_factory=dict)


class FrameProcessor(Protocol):
    """Takes the image so far, the grey frame and when it was captured (monotonic
    seconds; NaN if unknown); returns the image to show and its data. It draws on a
    copy, never on the image it is given. `find` gives the same data without drawing
    anything, for a frame nobody is shown."""

    name: str

    def process(self, image: np.ndarray, grey: np.ndarray, captured_at: float) -> Processed: ...

    def find(self, grey: np.ndarray, captured_at: float) -> dict[str, object]: ...


@dataclass(frozen=True)
class CameraIntrinsics:
    """A pinhole camera in OpenCV's terms: focal lengths and principal point in pixels
    (pixel centres at whole numbers), and the distortion coefficients of OpenCV's
    standard model (none: the frame is ideal, or already undistorted).

    sim/camera.py has the same class, field for field: the simulator imports nothing of
    the console, and the console's camera package nothing of the simulator."""

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = ()

    def matrix(self) -> np.ndarray:
        return np.array(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64
        )


class FastCorners:
    """FAST corners (Rosten and Drummond [7]), drawn as pink circles as in B.9."""

    name = "fast"

    def __init__(self, threshold: int = FAST_THRESHOLD) -> None:
        # The same function as cv2.FastFeatureDetector_create, in the spelling the stubs know.
        self.detector = cv2.FastFeatureDetector.create(threshold=threshold)

    def process(self, image: np.ndarray, grey: np.ndarray, captured_at: float) -> Processed:
        keypoints = self.detector.detect(grey)
        # None has OpenCV allocate the output image; the stubs wrongly refuse it.
        shown = cv2.drawKeypoints(image, keypoints, cast(np.ndarray, None), PINK)
        return Processed(shown, _corners_data(keypoints))

    def find(self, grey: np.ndarray, captured_at: float) -> dict[str, object]:
        return _corners_data(self.detector.detect(grey))


def _corners_data(keypoints: Sequence[cv2.KeyPoint]) -> dict[str, object]:
    return {"keypoints": len(keypoints), "corners": [k.pt for k in keypoints]}


class CannyEdges:
    """Canny edges over the whole frame, as in the thesis's Figure 5.1."""

    name = "canny"

    def process(self, image: np.ndarray, grey: np.ndarray, captured_at: float) -> Processed:
        edges = cv2.Canny(grey, CANNY_LOW, CANNY_HIGH)
        return Processed(
            cv2.cvtColor(edges, cv2.COLOR_GRAY2BGR), {"edge_pixels": int(np.count_nonzero(edges))}
        )

    def find(self, grey: np.ndarray, captured_at: float) -> dict[str, object]:
        return {"edge_pixels": int(np.count_nonzero(cv2.Canny(grey, CANNY_LOW, CANNY_HIGH)))}


class Pipeline:
    """Undistorts each frame if a calibration is given, then runs the enabled processors.

    The enabled processors are for the operator's eye: while the picture is not shown
    they do not run at all (issue 26: FAST ran ten times a second on a hidden camera).
    A processor that something needs whatever the operator shows (the marker detector,
    for localisation) is `require`d: it runs at the rate it is required at, shown or
    not, and on every frame while it is also enabled and shown (its drawing is then on
    screen)."""

    def __init__(self, processors: list[FrameProcessor],
                 undistortion: Undistortion | None = None) -> None:  # fmt: skip
        self.processors = {p.name: p for p in processors}
        self.undistortion = undistortion
        self.enabled: list[str] = []
        self.required: list[str] = []
        # Each required processor's period, seconds (0: every frame), and when it is
        # next due, by the frames' capture times.
        self._periods: dict[str, float] = {}
        self._due: dict[str, float] = {}

    def _known(self, name: str) -> None:
        if name not in self.processors:
            raise KeyError(f"no processor called {name!r}: {', '.join(self.processors)}")

    def toggle(self, name: str) -> bool:
        """Switch a processor on or off; returns whether it is on now."""
        self._known(name)
        if name in self.enabled:
            self.enabled.remove(name)
            return False
        self.enabled.append(name)
        return True

    def require(self, name: str, fps: float | None = None) -> None:
        """Run `name` from now on shown or not: on every frame, or on at most `fps`
        frames a second (the rate what needs it needs, not the camera's)."""
        self._known(name)
        if fps is not None and not fps > 0:
            raise ValueError(f"a processor's rate must be positive, not {fps}")
        if name not in self.required:
            self.required.append(name)
        self._periods[name] = 0.0 if fps is None else 1.0 / fps
        self._due[name] = -math.inf

    def _take(self, name: str, captured_at: float) -> bool:
        """Whether the frame captured at `captured_at` is one for `name` at its rate; if
        it is, the next is due a period after this one was. A quarter of a period's
        slack, so that a camera at just the required rate, whose frames come a little
        early or late, loses none of them (frames 99 ms apart at 10 a second would
        otherwise be taken every other one); one at three times the rate gives every
        third."""
        period = self._periods.get(name, 0.0)
        if not period or math.isnan(captured_at):
            return True
        due = self._due[name]
        if captured_at < due - period / 4:
            return False
        self._due[name] = (
            captured_at + period if due == -math.inf else max(due + period, captured_at)
        )
        return True

    def run(
        self, image: np.ndarray, captured_at: float = math.nan, shown: bool = True
    ) -> Processed:
        """The frame through the processors: the enabled ones only if it is `shown`, the
        required ones when due. A frame that is not shown and that none of them is to
        see is left as it is: neither undistorted nor turned grey."""
        drawn = self.enabled if shown else []
        for name in drawn:
            if name in self.required:
                self._take(name, captured_at)  # it runs now: the next is a period on
        needed = [n for n in self.required if n not in drawn and self._take(n, captured_at)]
        if not shown and not needed:
            return Processed(image)
        if self.undistortion is not None:
            image = self.undistortion.apply(image)
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        result = Processed(image)
        for name in drawn:
            step = self.processors[name].process(result.image, grey, captured_at)
            result = Processed(step.image, {**result.data, **step.data})
        for name in needed:
            # Not drawn: its drawing would not be shown.
            data = self.processors[name].find(grey, captured_at)
            result = Processed(result.image, {**result.data, **data})
        return result


class CalibrationError(ValueError):
    """A calibration file whose contents cannot undistort frames; the message says why."""


# No camera this console drives has a side longer; a calibration claiming more is garbage.
MAX_CALIBRATED_SIDE = 100_000
# OpenCV FileStorage's YAML: a `%YAML:1.0` line PyYAML does not take, and matrices
# tagged `!!opencv-matrix`. They are read here rather than by cv2.FileStorage, whose
# parser crashes the process (heap corruption, stack overflow) on some damaged files.
_OPENCV_HEADER = re.compile(rb"\A%YAML[:\s]1\.[0-9]\s*\n")
_OPENCV_MATRIX = b"!!opencv-matrix"


def _matrix(path: str, document: dict, key: str, shape: tuple[int, int]) -> np.ndarray:
    """The matrix `key` of an OpenCV calibration, of `shape` (either way round)."""
    node = document.get(key)
    data = node.get("data") if isinstance(node, dict) else None
    if not isinstance(data, list) or len(data) != shape[0] * shape[1]:
        raise CalibrationError(
            f"{path}: not a fisheye calibration: {key} should be a {shape[0]}x{shape[1]} matrix"
        )
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in data):
        raise CalibrationError(f"{path}: not a fisheye calibration: {key} should hold only numbers")
    try:
        matrix = np.array(data, dtype=np.float64).reshape(shape)
    except OverflowError:
        matrix = np.full(shape, np.inf)
    if not np.isfinite(matrix).all():
        raise CalibrationError(f"{path}: {key} holds numbers that are not finite")
    return matrix


def _side(path: str, document: dict, key: str) -> int:
    side = document.get(key)
    if isinstance(side, bool) or not isinstance(side, int) or not 1 <= side <= MAX_CALIBRATED_SIDE:
        raise CalibrationError(
            f"{path}: not a fisheye calibration: {key} should be a whole number of "
            f"pixels, 1 to {MAX_CALIBRATED_SIDE}"
        )
    return side


class Undistortion:
    """Removes the wide-angle lens's fisheye distortion, from an OpenCV calibration.

    The calibration file is OpenCV FileStorage's YAML with `camera_matrix` (3x3),
    `distortion_coefficients` (the fisheye model's four) and `image_width`/`image_height`.
    The maps are scaled to whatever resolution the camera delivers.
    """

    def __init__(self, camera_matrix: np.ndarray, distortion: np.ndarray,
                 size: tuple[int, int]) -> None:  # fmt: skip
        self.camera_matrix = np.asarray(camera_matrix, dtype=np.float64).reshape(3, 3)
        self.distortion = np.asarray(distortion, dtype=np.float64).reshape(4, 1)
        self.size = size
        self._maps: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}

    @classmethod
    def from_file(cls, path: str) -> Undistortion:
        """The calibration in `path`: OSError if it cannot be read, CalibrationError (a
        ValueError) for anything in it that is not a usable fisheye calibration, or for a
        file that is not a regular one or is larger than the limits (file_limits.py)."""
        try:
            data = read_bounded(path)
        except FileRefused as error:
            raise CalibrationError(f"{path}: {error}") from None
        data = _OPENCV_HEADER.sub(b"", data, count=1).replace(_OPENCV_MATRIX, b"")
        try:
            _, document = parse_yaml(data)
        except YamlSourceError as error:
            where = f"{path}:{error.line}" if error.line else path
            raise CalibrationError(f"{where}: {error.message}") from None
        if not isinstance(document, dict):
            raise CalibrationError(
                f"{path}: not a fisheye calibration (camera_matrix, distortion_coefficients, "
                "image_width and image_height in OpenCV's YAML)"
            )
        matrix = _matrix(path, document, "camera_matrix", (3, 3))
        distortion = _matrix(path, document, "distortion_coefficients", (4, 1))
        if not (matrix[0, 0] > 0 and matrix[1, 1] > 0):
            raise CalibrationError(f"{path}: the focal lengths fx and fy must be positive")
        size = (_side(path, document, "image_width"), _side(path, document, "image_height"))
        return cls(matrix, distortion, size)

    def scaled_matrix(self, size: tuple[int, int]) -> np.ndarray:
        """The camera matrix at another resolution than the calibration's."""
        scale = np.diag([size[0] / self.size[0], size[1] / self.size[1], 1.0])
        return scale @ self.camera_matrix

    def intrinsics(self, width: int, height: int) -> CameraIntrinsics:
        """The intrinsics of frames this has undistorted: `apply` remaps onto the
        calibration's own camera matrix (scaled to the frame), with no distortion left."""
        matrix = self.scaled_matrix((width, height))
        return CameraIntrinsics(matrix[0, 0], matrix[1, 1], matrix[0, 2], matrix[1, 2])

    def apply(self, image: np.ndarray) -> np.ndarray:
        size = (image.shape[1], image.shape[0])
        maps = self._maps.get(size)
        if maps is None:
            matrix = self.scaled_matrix(size)
            maps = cv2.fisheye.initUndistortRectifyMap(
                matrix, self.distortion, np.eye(3), matrix, size, cv2.CV_16SC2
            )
            self._maps[size] = maps
        return cv2.remap(image, maps[0], maps[1], cv2.INTER_LINEAR)
