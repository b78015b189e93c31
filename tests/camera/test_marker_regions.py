"""Finding markers in regions of a frame (issue 25): a region reaching a little beyond a
marker finds it exactly as the whole frame does, and finds nothing the whole frame
would not."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector, Region
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.marker_search import margin
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose

W, H = 800, 600
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)


@pytest.fixture(scope="module")
def care_home() -> tuple[WorldCamera, MarkerDetector]:
    camera = WorldCamera(plan_world(load_floorplan("giraff_console/floorplans/care-home.yaml")))

    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        known = camera.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)

    return camera, MarkerDetector("apriltag_36h11", 0.16, intrinsics)


def around(corners: np.ndarray) -> Region:
    """The region the eye gives a marker whose square has these corners."""
    low, high = corners.min(axis=0), corners.max(axis=0)
    reach = margin(float((high - low).max()))
    return Region(math.floor(low[0]) - reach, math.floor(low[1]) - reach,
                  math.ceil(high[0]) + 1 + reach, math.ceil(high[1]) + 1 + reach)  # fmt: skip


def test_a_marker_is_found_in_a_region_round_it_exactly_as_in_the_whole_frame(care_home):
    camera, detector = care_home
    compared = 0
    for x in np.arange(2.0, 34.0, 1.7):
        pose = TruePose(float(x), 10.9, 0.25 * math.cos(x))
        grey = cv2.cvtColor(camera.render(pose, W, H), cv2.COLOR_BGR2GRAY)
        whole = detector.detect(grey, 3.5)
        regional = detector.detect(grey, 3.5, [around(s.corners) for s in whole])
        assert [s.id for s in regional] == [s.id for s in whole]
        for a, b in zip(whole, regional, strict=True):
            assert np.array_equal(a.corners, b.corners)
            assert (a.distance_m, a.bearing_rad, a.facing_rad, a.frame_time) == (
                b.distance_m, b.bearing_rad, b.facing_rad, b.frame_time)  # fmt: skip
        compared += len(whole)
    assert compared >= 8


def test_a_region_finds_only_a_marker_wholly_inside_it(care_home):
    camera, detector = care_home
    grey = cv2.cvtColor(camera.render(TruePose(5.2, 10.9, 0.0), W, H), cv2.COLOR_BGR2GRAY)
    (sighting,) = detector.detect(grey)
    whole = around(sighting.corners)
    middle = int(sighting.corners[:, 0].mean())
    cut = Region(whole.left, whole.top, middle, whole.bottom)
    elsewhere = Region(0, 0, 200, 200)
    assert detector.detect(grey, regions=[cut, elsewhere]) == []
    assert [s.id for s in detector.detect(grey, regions=[whole])] == [sighting.id]


def test_a_region_passes_over_a_marker_too_small_for_the_whole_frame():
    # 8 pixels a side, a pixel a cell: under the whole frame's shortest outline (40 pixels
    # at 800), though a detector given the small region alone would find it.
    frame = np.full((H, W), 200, dtype=np.uint8)
    frame[280:320, 380:420] = 245
    frame[296:304, 396:404] = cv2.aruco.generateImageMarker(DICTIONARY, 5, 8, borderBits=1)
    detector = MarkerDetector("apriltag_36h11", 0.16)
    region = Region(370, 270, 430, 330)
    assert detector.detect(frame) == []
    assert detector.detect(frame, regions=[region]) == []
    alone = detector.detector.detectMarkers(frame[270:330, 370:430].copy())[1]
    assert alone is not None and alone.ravel().tolist() == [5]


def test_regions_past_the_frame_s_edges_are_cut_to_it(care_home):
    camera, detector = care_home
    grey = cv2.cvtColor(camera.render(TruePose(5.2, 10.9, 0.0), W, H), cv2.COLOR_BGR2GRAY)
    everything = detector.detect(grey)
    assert everything
    beyond = [Region(-50, -50, W + 50, H + 50), Region(W + 10, 0, W + 90, 80)]
    assert [s.id for s in detector.detect(grey, regions=beyond)] == [s.id for s in everything]


def test_a_marker_in_two_overlapping_regions_is_found_once(care_home):
    camera, detector = care_home
    grey = cv2.cvtColor(camera.render(TruePose(5.2, 10.9, 0.0), W, H), cv2.COLOR_BGR2GRAY)
    (sighting,) = detector.detect(grey)
    region = around(sighting.corners)
    wider = Region(region.left - 10, region.top - 10, region.right + 10, region.bottom + 10)
    assert [s.id for s in detector.detect(grey, regions=[region, wider])] == [sighting.id]
