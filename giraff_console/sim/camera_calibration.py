"""The synthetic camera's calibration file, as a real camera's would be handed over.

A real camera's intrinsics come from its calibration, which the console reads with
`--calibration` (OpenCV's fisheye model, for the Giraff's wide-angle lens). The
simulated camera across a socket hands the console the same kind of file, so that the
console learns its intrinsics the way it learns a real one's, never from the simulator.

The synthetic camera is an ideal pinhole (sim/camera.py). OpenCV's fisheye model maps a
ray theta off the axis to theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8) where a
pinhole has tan(theta): with all four k at zero it is not the pinhole but an equidistant
lens, and the console's undistortion would bend the picture by a hundred pixels in the
corners. So the k are fitted to tan(theta) over the frame's angles, as calibrating the
camera on a chessboard would find them; the undistortion is then the identity to within
a hundredth of a pixel, and the camera matrix the pinhole's.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from giraff_console.sim.camera import WorldCamera

# The console's default resolution (§3.3). The console scales the calibration to the
# size it reads, which is exact for the other 4:3 sizes it offers (keys 1-5), to within
# the half pixel of the principal point.
CALIBRATED_SIZE = (800, 600)
# Rays this much further off the axis than the frame's corners are fitted too.
ANGLE_MARGIN = 1.05


def pinhole_as_fisheye(max_angle: float) -> np.ndarray:
    """The fisheye model's k1..k4 that make it a pinhole for rays up to `max_angle`
    radians off the axis: least squares of theta_d - theta against tan(theta) - theta."""
    theta = np.linspace(0.0, max_angle, 2000)
    powers = np.stack([theta**3, theta**5, theta**7, theta**9], axis=1)
    coefficients, *_ = np.linalg.lstsq(powers, np.tan(theta) - theta, rcond=None)
    return coefficients


def calibration_text(camera: WorldCamera, size: tuple[int, int] = CALIBRATED_SIZE) -> str:
    """The camera's calibration at `size` in OpenCV FileStorage's YAML, with the keys
    the console reads (camera/processors.py Undistortion)."""
    width, height = size
    known = camera.intrinsics(width, height)
    corner = math.hypot(max(known.cx, width - 1 - known.cx) + 0.5,
                        max(known.cy, height - 1 - known.cy) + 0.5)  # fmt: skip
    max_angle = min(math.atan(corner / min(known.fx, known.fy)) * ANGLE_MARGIN, 1.5)
    coefficients = pinhole_as_fisheye(max_angle)
    matrix = [known.fx, 0.0, known.cx, 0.0, known.fy, known.cy, 0.0, 0.0, 1.0]

    def data(values) -> str:
        return ", ".join(repr(float(value)) for value in values)

    return (
        "%YAML:1.0\n---\n"
        "# The simulator's synthetic camera: an ideal pinhole, in OpenCV's fisheye model\n"
        "# (giraff_console/sim/camera_calibration.py).\n"
        f"image_width: {width}\nimage_height: {height}\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        f"   data: [ {data(matrix)} ]\n"
        "distortion_coefficients: !!opencv-matrix\n   rows: 4\n   cols: 1\n   dt: d\n"
        f"   data: [ {data(coefficients)} ]\n"
    )


def write_calibration(path: Path, camera: WorldCamera) -> None:
    """Write the camera's calibration to `path`, whole or not at all: a console reading
    it as the simulator starts never sees half a file."""
    partial = path.with_name(f".{path.name}.partial")
    with open(partial, "w", encoding="ascii") as file:
        file.write(calibration_text(camera))
    os.replace(partial, path)
