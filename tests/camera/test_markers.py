"""The marker processor: detection, poses, drawing, and how it plugs into the pipeline."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.camera.feed import CameraFeed
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.markers import (
    MARKER_GREEN,
    CameraIntrinsics,
    CameraMount,
    MarkerDetector,
    aruco_dictionary,
    refine_corners,
)
from giraff_console.camera.processors import FastCorners, Pipeline, Undistortion
from giraff_console.camera.source import SyntheticCamera
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import Wall, World, WorldMarker, marker_pattern

FAMILY = "apriltag_36h11"
SIZE = 0.16
DICTIONARY = aruco_dictionary(FAMILY)
ROOM = [Wall(-5, -5, 5, -5), Wall(5, -5, 5, 5), Wall(5, 5, -5, 5), Wall(-5, 5, -5, -5)]
CAMERA = WorldCamera(World(ROOM, [WorldMarker(7, 5.0, 0.0, 1.1, math.pi, SIZE,
                                              marker_pattern(DICTIONARY, 7))]))  # fmt: skip
POSE = TruePose(3.0, 0.1, 0.05)  # 2 m from marker 7, facing it


def synthetic(width: int, height: int) -> CameraIntrinsics:
    known = CAMERA.intrinsics(width, height)
    return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy, known.distortion)


def frame(width: int = 800, height: int = 600) -> np.ndarray:
    return CAMERA.render(POSE, width, height)


def printed(marker_id: int, side: int, at: tuple[int, int], shape=(480, 640)) -> np.ndarray:
    """A marker pasted flat into a white picture, its black square `side` pixels wide
    with its top-left corner at `at`."""
    image = np.full((*shape, 3), 235, dtype=np.uint8)
    marker = cv2.aruco.generateImageMarker(DICTIONARY, marker_id, side)
    x, y = at
    image[y : y + side, x : x + side] = marker[:, :, None]
    return image


def test_families_are_cv2_aruco_dictionaries_by_their_plan_names():
    assert aruco_dictionary("apriltag_36h11").markerSize == 6
    assert aruco_dictionary("4x4_50").markerSize == 4
    with pytest.raises(ValueError, match="unknown marker family"):
        aruco_dictionary("qr_code")
    with pytest.raises(ValueError):
        MarkerDetector(FAMILY, 0.0)


def test_the_pipeline_outlines_markers_with_their_ids_when_on():
    pipeline = Pipeline([FastCorners(), MarkerDetector(FAMILY, SIZE, synthetic)])
    image = frame()
    assert pipeline.run(image).data == {}
    assert pipeline.toggle("markers")
    result = pipeline.run(image, captured_at=4.0)
    [sighting] = result.data["markers"]
    assert result.data["marker_ids"] == [7] and sighting.frame_time == 4.0
    assert sighting.distance_m == pytest.approx(math.hypot(2.0, 0.1), abs=0.03)
    # Green outline over the marker's edge, thick enough for the terminal's shrink.
    green = np.all(result.image == MARKER_GREEN, axis=2)
    corners = np.round(sighting.corners).astype(int)
    x0, y0 = corners.min(axis=0)
    x1, y1 = corners.max(axis=0)
    assert green[y0 - 3 : y1 + 4, x0 - 3 : x1 + 4].sum() > 4 * (x1 - x0) * 2
    assert not np.array_equal(result.image, image)
    assert np.array_equal(image, frame())  # drawn on a copy


def test_a_required_processor_runs_unseen_while_off():
    """Localisation needs the sightings whatever the operator chooses to show."""
    pipeline = Pipeline([MarkerDetector(FAMILY, SIZE, synthetic)])
    pipeline.require("markers")
    image = frame()
    result = pipeline.run(image)
    assert result.data["marker_ids"] == [7]
    assert np.array_equal(result.image, image)  # nothing drawn while it is not shown
    pipeline.toggle("markers")
    assert not np.array_equal(pipeline.run(image).image, image)
    with pytest.raises(KeyError):
        pipeline.require("sift")


def test_without_intrinsics_a_marker_is_found_but_not_placed():
    [sighting] = MarkerDetector(FAMILY, SIZE).detect(cv2.cvtColor(frame(), cv2.COLOR_BGR2GRAY))
    assert sighting.id == 7
    assert math.isnan(sighting.distance_m) and math.isnan(sighting.bearing_rad)


def test_the_pose_follows_the_intrinsics_and_the_mount():
    """A marker pasted square to a camera with f = 500: its distance is f * size / side;
    a camera pitched down sees it lower and nearer along the floor."""
    intrinsics = CameraIntrinsics(500.0, 500.0, 319.5, 239.5)
    side = 80  # the black square's pixels, so 1 m off for a 0.16 m marker
    # Centred on the principal point's column, 100 pixels to its left.
    image = printed(11, side, (round(319.5 - 100 - side / 2 + 0.5), round(239.5 - side / 2 + 0.5)))
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    level = MarkerDetector(FAMILY, SIZE, lambda w, h: intrinsics)
    [sighting] = level.detect(grey)
    assert sighting.id == 11
    forward, left = 1.0, 100 / 500
    assert sighting.distance_m == pytest.approx(math.hypot(forward, left), abs=0.01)
    assert sighting.bearing_rad == pytest.approx(math.atan2(left, forward), abs=0.005)
    assert abs(abs(sighting.facing_rad) - math.pi) < math.radians(3)
    pitch = math.radians(20)
    mounted = MarkerDetector(FAMILY, SIZE, lambda w, h: intrinsics, CameraMount(0.1, pitch))
    [pitched] = mounted.detect(grey)
    # The marker's centre is 1 m along the optical axis, which dips by 20 degrees; the
    # camera is 0.1 m ahead of the axle.
    assert pitched.distance_m == pytest.approx(math.hypot(math.cos(pitch) + 0.1, left), abs=0.01)


def test_refined_corners_sit_on_the_square_s_edges():
    side = 48
    image = cv2.GaussianBlur(printed(3, side, (100, 120)), (3, 3), 0)
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    detector = cv2.aruco.ArucoDetector(DICTIONARY)
    corners, _, _ = detector.detectMarkers(grey)
    raw = corners[0].reshape(4, 2).astype(np.float64)
    # The pasted square's pixels run from 100 to 147: its edges are half a pixel out.
    true = np.array([[99.5, 119.5], [147.5, 119.5], [147.5, 167.5], [99.5, 167.5]])
    refined = refine_corners(grey, raw, 8)
    assert np.abs(refined - true).max() < 0.05 < np.abs(raw - true).max()


def test_a_calibrated_camera_s_frames_are_undistorted_first(tmp_path):
    """With --calibration the pipeline undistorts before any processor, onto the
    calibration's own camera matrix: those are the intrinsics that then apply."""
    known = synthetic(800, 600)
    matrix = known.matrix()
    coefficients = np.array([-0.05, 0.01, 0.0, 0.0]).reshape(4, 1)
    path = tmp_path / "calibration.yaml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", matrix)
    storage.write("distortion_coefficients", coefficients)
    storage.write("image_width", 800)
    storage.write("image_height", 600)
    storage.release()
    undistortion = Undistortion.from_file(str(path))
    at = undistortion.intrinsics(800, 600)
    assert (at.fx, at.cx, at.distortion) == (known.fx, known.cx, ())
    assert undistortion.intrinsics(400, 300).fx == pytest.approx(known.fx / 2)
    # What a fisheye lens would have made of the synthetic frame: each distorted pixel
    # takes the ideal pixel its ray comes from.
    ys, xs = np.mgrid[0:600, 0:800].astype(np.float64)
    rays = cv2.fisheye.undistortPoints(
        np.stack([xs.ravel(), ys.ravel()], -1)[None], matrix, coefficients
    )[0]
    ideal = rays @ matrix[:2, :2].T + matrix[:2, 2]
    maps = ideal.reshape(600, 800, 2).astype(np.float32)
    distorted = cv2.remap(frame(), maps[..., 0], maps[..., 1], cv2.INTER_LINEAR)
    detector = MarkerDetector(FAMILY, SIZE, undistortion.intrinsics)
    pipeline = Pipeline([detector], undistortion)
    pipeline.toggle("markers")
    [sighting] = pipeline.run(distorted).data["markers"]
    assert sighting.distance_m == pytest.approx(math.hypot(2.0, 0.1), abs=0.03)
    bearing = math.atan2(-0.1, 2.0) - POSE.heading
    assert math.degrees(abs(sighting.bearing_rad - bearing)) < 1.0


def test_the_feed_hands_sightings_to_listeners_and_ids_to_the_picture():
    source = SyntheticCamera(lambda width, height: CAMERA.render(POSE, width, height),
                             clock=lambda: 99.0)  # fmt: skip
    pipeline = Pipeline([MarkerDetector(FAMILY, SIZE, synthetic)])
    pipeline.require("markers")
    heard = []
    feed = CameraFeed(source, (800, 600), pipeline, HalfBlockRenderer(), lambda picture: None)
    feed.listeners.append(lambda captured, data: heard.append((captured, data)))
    picture = feed.picture()
    assert picture.markers == (7,)
    [(captured, data)] = heard
    assert captured.captured_at == 99.0 and [s.frame_time for s in data["markers"]] == [99.0]


def test_the_plan_s_markers_hang_in_the_simulated_building():
    plan = load_floorplan("giraff_console/floorplans/care-home.yaml")
    assert plan.landmarks is not None
    world = plan_world(plan)
    assert [m.id for m in world.markers] == [m.id for m in plan.landmarks.markers]
    first, placed = plan.landmarks.markers[0], world.markers[0]
    assert (placed.x, placed.y, placed.height) == (*first.at, first.height)
    assert placed.facing == pytest.approx(math.radians(first.facing))
    assert placed.size == plan.landmarks.size
    assert np.array_equal(placed.pattern, marker_pattern(DICTIONARY, first.id))
    # And the camera, 1.5 m in front of one, sees it by its id.
    camera = WorldCamera(world)
    pose = TruePose(
        placed.x + 1.5 * math.cos(placed.facing),
        placed.y + 1.5 * math.sin(placed.facing),
        placed.facing + math.pi,
    )
    image = camera.render(pose, 800, 600)

    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        known = camera.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)

    found = MarkerDetector(plan.landmarks.family, plan.landmarks.size, intrinsics).detect(
        cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    )
    assert placed.id in [s.id for s in found]


def test_a_detector_told_the_plan_s_ids_finds_those_alone_by_their_own_ids():
    pair = [WorldMarker(i, 5.0, y, 1.1, math.pi, SIZE, marker_pattern(DICTIONARY, i))
            for i, y in ((3, -0.6), (250, 0.6))]  # fmt: skip
    image = WorldCamera(World(ROOM, pair)).render(TruePose(3.0, 0.0, 0.0), 800, 600)
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    every = {s.id: s for s in MarkerDetector(FAMILY, SIZE, synthetic).detect(grey)}
    assert set(every) == {3, 250}
    # The detector numbers the few it knows from 0; the sightings keep the markers' ids.
    [only] = MarkerDetector(FAMILY, SIZE, synthetic, ids=[250, 9]).detect(grey)
    assert only.id == 250 and np.array_equal(only.corners, every[250].corners)
    assert MarkerDetector(FAMILY, SIZE, synthetic, ids=[]).detect(grey) == []
    with pytest.raises(ValueError, match="markers 0 to 586"):
        MarkerDetector(FAMILY, SIZE, ids=[3, 587])


def test_looking_for_the_plan_s_markers_alone_finds_the_same_sightings():
    plan = load_floorplan("giraff_console/floorplans/care-home.yaml")
    camera = WorldCamera(plan_world(plan))
    ids = [marker.id for marker in plan.landmarks.markers]
    everything = MarkerDetector(plan.landmarks.family, plan.landmarks.size, synthetic)
    planned = MarkerDetector(plan.landmarks.family, plan.landmarks.size, synthetic, ids=ids)
    found = 0
    for marker in camera.world.markers[::30]:
        # 2 m in front of it, a little to one side, turned a little away.
        slant = math.radians(20)
        pose = TruePose(
            marker.x + 2.0 * math.cos(marker.facing + slant),
            marker.y + 2.0 * math.sin(marker.facing + slant),
            marker.facing + slant + math.pi + math.radians(10),
        )
        grey = cv2.cvtColor(camera.render(pose, 800, 600), cv2.COLOR_BGR2GRAY)
        expected, seen = everything.detect(grey), planned.detect(grey)
        assert [s.id for s in seen] == [s.id for s in expected]
        for a, b in zip(seen, expected, strict=True):
            assert np.array_equal(a.corners, b.corners) and a.distance_m == b.distance_m
        found += len(seen)
    assert found >= 6


def test_a_hidden_feed_still_hands_frames_to_the_localisation_but_draws_nothing():
    source = SyntheticCamera(lambda width, height: CAMERA.render(POSE, width, height),
                             clock=lambda: 99.0)  # fmt: skip
    pipeline = Pipeline([MarkerDetector(FAMILY, SIZE, synthetic)])
    pipeline.require("markers")
    drawn, heard = [], []
    renderer = HalfBlockRenderer()
    render = renderer.render
    renderer.render = lambda *args: drawn.append(1) or render(*args)  # type: ignore[method-assign]
    feed = CameraFeed(source, (800, 600), pipeline, renderer, lambda picture: None)
    feed.shown = False
    assert not feed.wanted  # nothing needs a frame: the camera's thread takes none
    feed.listeners.append(lambda captured, data: heard.append(data["marker_ids"]))
    assert feed.wanted
    assert feed.picture() is None
    assert heard == [[7]] and drawn == []
    feed.shown = True
    assert feed.picture().markers == (7,) and drawn == [1]
