"""The synthetic camera drawn only round the markers, for the eye without a screen (issue
25): inside its windows every pixel is the whole picture's, a marker that no detector
could make out or that a wall hides gets none, and only the windows asked for are read
out."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim.camera import Box, WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.marker_windows import UNDRAWN, WINDOW_MARGIN_PX, MarkerWindows
from giraff_console.sim.surroundings import Surroundings
from giraff_console.sim.world import Wall, World, WorldMarker, marker_pattern

DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
W, H = 800, 600
# A 10 m square room; markers 7 and 8 on its east wall, looking west into it.
ROOM = [Wall(-5, -5, 5, -5), Wall(5, -5, 5, 5), Wall(5, 5, -5, 5), Wall(-5, 5, -5, -5)]


def marker(marker_id: int, x: float, y: float, facing_deg: float = 180.0) -> WorldMarker:
    return WorldMarker(marker_id, x, y, 1.1, math.radians(facing_deg), 0.16,
                       marker_pattern(DICTIONARY, marker_id))  # fmt: skip


@pytest.fixture(scope="module")
def care_home() -> WorldCamera:
    return WorldCamera(plan_world(load_floorplan("giraff_console/floorplans/care-home.yaml")))


def test_any_box_of_the_picture_is_drawn_as_the_whole_picture_has_it():
    # Boxes at the picture's corners, across the horizon, round a marker and in front of
    # a box on the floor and a closed door: each pixel is worked out from its own ray.
    surroundings = Surroundings()
    surroundings.block(3.0, -1.0)
    surroundings.close_door("d", (5.0, 1.5), (5.0, 2.5))
    camera = WorldCamera(World(ROOM, [marker(7, 5.0, 0.0)]), surroundings=surroundings)
    pose = TruePose(1.0, 0.3, 0.1)
    whole = camera.draw(pose, Box.whole(W, H))
    for left, top, right, bottom in [
        (0, 0, 37, 50),
        (100, 250, 330, 420),
        (W - 41, H - 29, W, H),
        (380, 280, 430, 330),
        (0, 299, W, 301),
        (150, 320, 260, 600),
    ]:
        drawn = camera.draw(pose, Box(W, H, left, top, right, bottom))
        assert np.array_equal(drawn, whole[top:bottom, left:right]), (left, top, right, bottom)


@pytest.mark.parametrize(
    "pose",
    [TruePose(5.2, 10.9, 0.0), TruePose(2.0, 10.4, 1.42), TruePose(37.8, 7.2, -0.8),
     TruePose(31.2, 10.9, 0.0)],
)  # fmt: skip
def test_inside_its_windows_the_picture_is_the_whole_render_and_flat_outside(care_home, pose):
    windows = MarkerWindows(care_home)
    boxes = windows.windows(pose, W, H)
    assert boxes
    drawn, whole = windows.render(pose, W, H), care_home.render(pose, W, H)
    outside = np.ones((H, W), dtype=bool)
    for box in boxes:
        inside = (slice(box.top, box.bottom), slice(box.left, box.right))
        assert np.array_equal(drawn[inside], whole[inside])
        outside[inside] = False
    assert (drawn[outside] == UNDRAWN).all()


def test_every_marker_the_whole_picture_shows_is_found_the_same_in_the_windows(care_home):
    from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector

    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        known = care_home.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)

    detector = MarkerDetector("apriltag_36h11", 0.16, intrinsics)
    windows = MarkerWindows(care_home)
    found = 0
    for x in np.arange(3.0, 30.0, 2.3):
        pose = TruePose(float(x), 10.9, 0.3 * math.sin(x))
        whole = detector.detect(cv2.cvtColor(care_home.render(pose, W, H), cv2.COLOR_BGR2GRAY))
        seen = detector.detect(cv2.cvtColor(windows.render(pose, W, H), cv2.COLOR_BGR2GRAY))
        assert [(s.id, s.distance_m, s.bearing_rad) for s in seen] == [
            (s.id, s.distance_m, s.bearing_rad) for s in whole
        ]
        for sighting in seen:
            # Its square stands well inside a window, with paper and margin round it
            # (but where the window meets the picture's edge).
            low, high = sighting.corners.min(axis=0), sighting.corners.max(axis=0)
            assert any(inner(box, 0) <= low[0] and high[0] <= inner(box, 2)
                       and inner(box, 1) <= low[1] and high[1] <= inner(box, 3)
                       for box in windows.windows(pose, W, H))  # fmt: skip
        found += len(seen)
    assert found >= 5


def inner(box: Box, side: int) -> float:
    """Where `box` ends on its left, top, right or bottom side (0 to 3) less the window's
    margin, unless it ends at the picture's edge."""
    edge = (box.left, box.top, box.right, box.bottom)[side]
    if edge in (0, (W, H)[side % 2]):
        return edge
    return edge + WINDOW_MARGIN_PX if side < 2 else edge - WINDOW_MARGIN_PX


def test_no_window_for_a_marker_behind_a_wall_or_too_far_to_make_out():
    # A 40 m hall: marker 1 at its far end (2 pixels a page at 800 pixels), marker 2 on
    # a screen behind a partition, marker 3 on a screen in plain view beside it.
    hall = [Wall(-1, -3, 40, -3), Wall(40, -3, 40, 3), Wall(40, 3, -1, 3), Wall(-1, 3, -1, -3),
            Wall(3, -0.5, 3, -2.5), Wall(5, -2, 5, -1), Wall(5, 0.5, 5, 1.5)]  # fmt: skip
    markers = [marker(1, 40.0, 0.0), marker(2, 5.0, -1.5), marker(3, 5.0, 1.0)]
    windows = MarkerWindows(WorldCamera(World(hall, markers)))
    pose = TruePose(0.0, 0.0, 0.0)
    boxes = windows.windows(pose, W, H)
    assert len(boxes) == 1
    # The one window is marker 3's, to the left of the picture's middle.
    assert boxes[0].right < W / 2


def test_only_the_windows_asked_for_are_read_out_and_the_rest_is_black():
    camera = WorldCamera(World(ROOM, [marker(7, 5.0, -0.8), marker(8, 5.0, 0.8)]))
    windows = MarkerWindows(camera)
    pose = TruePose(2.0, 0.0, 0.0)
    right, left = sorted(windows.windows(pose, W, H), key=lambda box: -box.left)
    asked = (right.left + 5, right.top + 5, right.left + 15, right.top + 15)
    drawn = windows.render(pose, W, H, [asked])
    whole = camera.render(pose, W, H)
    inside = (slice(right.top, right.bottom), slice(right.left, right.right))
    assert np.array_equal(drawn[inside], whole[inside])
    assert not drawn[left.top : left.bottom, left.left : left.right].any()
    assert not drawn[:, : right.left].any()
