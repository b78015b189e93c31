"""Frame processors, sources with their fallbacks, and the half-block renderer."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from giraff_console.camera.halfblock import HalfBlockRenderer, fit, quantise
from giraff_console.camera.processors import CannyEdges, FastCorners, Pipeline, Undistortion
from giraff_console.camera.source import SyntheticCamera, TestPattern, open_camera

RECTANGLES = [((40, 30), (100, 90)), ((150, 50), (220, 140))]


def drawn_image() -> np.ndarray:
    """White rectangles on black, softened as any lens would (FAST ignores ideal steps)."""
    image = np.zeros((200, 260, 3), dtype=np.uint8)
    for (x0, y0), (x1, y1) in RECTANGLES:
        image[y0:y1, x0:x1] = 255
    return cv2.GaussianBlur(image, (3, 3), 0)


def test_fast_finds_the_corners_of_drawn_rectangles():
    pipeline = Pipeline([FastCorners(), CannyEdges()])
    assert pipeline.toggle("fast")
    result = pipeline.run(drawn_image())
    found = np.array(result.data["corners"])
    expected = [
        (x, y) for (x0, y0), (x1, y1) in RECTANGLES for x in (x0, x1 - 1) for y in (y0, y1 - 1)
    ]
    for corner in expected:
        assert np.min(np.hypot(*(found - corner).T)) <= 3, corner
    assert result.data["keypoints"] == len(found)
    assert (result.image[..., 1] == 0).any()  # pink drawn over the frame


def test_canny_and_toggling():
    pipeline = Pipeline([FastCorners(), CannyEdges()])
    pipeline.toggle("canny")
    assert pipeline.run(drawn_image()).data["edge_pixels"] > 400
    assert not pipeline.toggle("canny")
    assert pipeline.run(drawn_image()).data == {}
    with pytest.raises(KeyError):
        pipeline.toggle("sift")


def test_a_missing_camera_falls_back_and_says_so():
    camera, size, note = open_camera("/dev/no-such-camera", 640, 480, synthetic=None)
    assert isinstance(camera, TestPattern) and size == (640, 480)
    assert "not found" in note and "test pattern" in note
    assert camera.read().image.shape == (480, 640, 3)
    synthetic = SyntheticCamera(lambda w, h: np.zeros((h, w, 3), np.uint8))
    camera, _, note = open_camera(None, 800, 600, synthetic=synthetic)
    assert camera is synthetic and "synthetic camera" in note


def test_half_block_cells_carry_the_upper_and_lower_colours():
    # Top row red, green; bottom row blue, white (BGR).
    image = np.array([[[0, 0, 255], [0, 255, 0]], [[255, 0, 0], [255, 255, 255]]], dtype=np.uint8)
    (line,) = HalfBlockRenderer(truecolor=True).render(image, 2, 1)
    cells = [(segment.style.color.triplet, segment.style.bgcolor.triplet) for segment in line]
    hi, lo = int(quantise(np.array([255]), 16)[0]), int(quantise(np.array([0]), 16)[0])
    assert [tuple(c) for pair in cells for c in pair] == [
        (hi, lo, lo), (lo, lo, hi), (lo, hi, lo), (hi, hi, hi),
    ]  # fmt: skip
    assert all(segment.text == "▀" for segment in line)


def test_half_blocks_in_256_colours_and_runs_merge():
    image = np.zeros((4, 8, 3), dtype=np.uint8)
    line = HalfBlockRenderer(truecolor=False).render(image, 8, 2)[0]
    assert len(line) == 1 and line[0].text == "▀" * 8
    assert line[0].style.color.number == 16  # black in the colour cube


def test_the_view_keeps_the_aspect_ratio_within_the_pane():
    assert fit(800, 600, 100, 30) == (80, 60)
    assert fit(800, 600, 40, 30) == (40, 30)


def test_undistortion_puts_a_distorted_point_back_where_it_belongs(tmp_path):
    matrix = np.array([[300.0, 0, 320], [0, 300.0, 240], [0, 0, 1]])
    coefficients = np.array([-0.05, 0.01, 0.0, 0.0])
    path = tmp_path / "calibration.yaml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", matrix)
    storage.write("distortion_coefficients", coefficients.reshape(4, 1))
    storage.write("image_width", 640)
    storage.write("image_height", 480)
    storage.release()
    undistortion = Undistortion.from_file(str(path))
    true_point = np.array([[[520.0, 400.0]]])
    normalised = cv2.undistortPoints(true_point, matrix, None)  # onto the image plane
    seen = cv2.fisheye.distortPoints(normalised, matrix, coefficients.reshape(4, 1))[0, 0]
    image = np.zeros((480, 640, 3), dtype=np.uint8)
    cv2.circle(image, (round(seen[0]), round(seen[1])), 3, (255, 255, 255), -1)
    assert np.hypot(*(seen - true_point[0, 0])) > 5  # the lens really moved it
    corrected = undistortion.apply(image)
    ys, xs = np.nonzero(corrected[..., 0] > 128)
    assert np.hypot(xs.mean() - 520, ys.mean() - 400) <= 1.5
    # A frame of another resolution gets scaled maps.
    assert undistortion.apply(cv2.resize(image, (320, 240))).shape == (240, 320, 3)


def test_a_bad_calibration_file_is_refused(tmp_path):
    path = tmp_path / "nonsense.yaml"
    path.write_text("%YAML:1.0\nfoo: 1\n")
    with pytest.raises(ValueError, match="not a fisheye calibration"):
        Undistortion.from_file(str(path))
    with pytest.raises(OSError):
        Undistortion.from_file(str(tmp_path / "missing.yaml"))


def test_the_console_falls_back_to_a_test_pattern_and_says_why():
    from giraff_console.runtime.camera import camera_feed

    feed = camera_feed("/dev/no-such-camera", None, fast_threshold=30, fps=5)
    assert "not found" in feed.note and "test pattern" in feed.note
    assert feed.period == pytest.approx(0.2)
    feed.set_cells(40, 10)
    picture = feed.picture()
    assert picture.source == "test pattern" and picture.keypoints is not None
    assert len(picture.lines) <= 10
