"""Where the marker eye looks in each frame (issue 25): round the markers it tracks and
those the plan and the estimate put in view, the whole frame now and then and after a
turn, nowhere when there is nothing to look for. Frames come from the synthetic camera;
the search itself reads only the estimate, the plan and the pixels' sightings."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector, Region
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.marker_search import SEARCH_TURN_RAD, Building, MarkerSearch
from giraff_console.robot.odometry import Pose
from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import Wall, World, WorldMarker, marker_pattern

W, H = 800, 600
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
# A 10 m square room; marker 7 in the middle of its east wall, looking west into it.
ROOM = [Wall(-5, -5, 5, -5), Wall(5, -5, 5, 5), Wall(5, 5, -5, 5), Wall(-5, 5, -5, -5)]
SEVEN = WorldMarker(7, 5.0, 0.0, 1.1, math.pi, 0.16, marker_pattern(DICTIONARY, 7))
CAMERA = WorldCamera(World(ROOM, [SEVEN]))
PLAN = {7: Pose(5.0, 0.0, math.pi)}
WALLS = np.array([((w.x1, w.y1), (w.x2, w.y2)) for w in ROOM])
BUILDING = Building(CAMERA_HEIGHT_M, {7: 1.1}, WALLS)


def intrinsics(width: int, height: int) -> CameraIntrinsics:
    known = CAMERA.intrinsics(width, height)
    return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)


DETECTOR = MarkerDetector("apriltag_36h11", 0.16, intrinsics, ids=[7])


class Believed:
    """What the search reads of the localisation: the plan's markers, and an estimate the
    test sets (and the odometry's pose, the estimate's unless told)."""

    def __init__(self, pose: Pose, markers: dict[int, Pose] | None = None) -> None:
        self.markers = PLAN if markers is None else markers
        self.pose, self.odometry = pose, pose
        self.sigma_m, self.sigma_heading = 0.02, math.radians(1)
        self.found = True

    def estimate(self) -> Estimate:
        s, h = self.sigma_m, self.sigma_heading
        return Estimate(self.pose, self.odometry, ((s * s, 0, 0), (0, s * s, 0), (0, 0, h * h)),
                        s, h, (s, s, 0.0), landmarks=True, found=self.found)  # fmt: skip


def square(pose: TruePose) -> np.ndarray:
    """Marker 7's corners as the detector finds them in the whole picture from `pose`."""
    grey = cv2.cvtColor(CAMERA.render(pose, W, H), cv2.COLOR_BGR2GRAY)
    (sighting,) = DETECTOR.detect(grey)
    return sighting.corners


def holds(regions: list[Region], corners: np.ndarray) -> bool:
    low, high = corners.min(axis=0), corners.max(axis=0)
    return any(r.left <= low[0] and high[0] < r.right and r.top <= low[1] and high[1] < r.bottom
               for r in regions)  # fmt: skip


def searched(believed: Believed, building: Building = BUILDING, **kwargs) -> MarkerSearch:
    """A search past its first frame, searched whole before the plan had markers (so
    that none was missed in it)."""
    markers, believed.markers = believed.markers, {}
    search = MarkerSearch(believed, DETECTOR, building, **kwargs)  # type: ignore[arg-type]
    assert search.regions(W, H) is None
    search.seen([])
    believed.markers = markers
    return search


def test_a_marker_in_view_is_looked_for_in_a_small_box_where_it_shows():
    pose = TruePose(2.0, 0.3, 0.1)
    search = searched(Believed(Pose(2.01, 0.29, 0.11)))
    regions = search.regions(W, H)
    assert regions is not None and len(regions) == 1
    assert holds(regions, square(pose))
    assert regions[0].area < 0.05 * W * H


def test_without_heights_a_marker_is_looked_for_the_whole_height_of_the_frame():
    search = searched(Believed(Pose(2.0, 0.3, 0.1)), Building(walls=WALLS))
    (region,) = search.regions(W, H) or []
    assert (region.top, region.bottom) == (0, H)
    assert holds([region], square(TruePose(2.0, 0.3, 0.1)))


@pytest.mark.parametrize(
    ("pose", "plan", "walls"),
    [
        (Pose(2.0, 0.0, math.pi), PLAN, WALLS),  # behind the camera
        (Pose(2.0, 0.0, 0.0), {7: Pose(5.0, 0.0, 0.0)}, WALLS),  # faces the other way
        (Pose(2.0, 0.0, 0.0), PLAN, np.vstack([WALLS, [((3.5, -1.0), (3.5, 1.0))]])),  # a wall
        (Pose(-25.0, 0.0, 0.0), PLAN, WALLS[:0]),  # 30 m off: too small to find
    ],
)  # fmt: skip
def test_with_nothing_to_look_for_the_frame_is_not_taken(pose, plan, walls):
    search = searched(Believed(pose, plan), Building(CAMERA_HEIGHT_M, {7: 1.1}, walls))
    assert search.regions(W, H) == []


def test_the_whole_frame_is_searched_every_search_every_frames():
    search = searched(Believed(Pose(2.0, 0.0, 0.0)), search_every=4)
    whole = [search.regions(W, H) is None for _ in range(12)]
    assert whole == [False, False, False, True] * 3


def test_and_as_soon_as_the_robot_has_turned_to_a_new_view():
    believed = Believed(Pose(2.0, 0.0, 0.0))
    search = searched(believed, search_every=100)
    turns = [0.3, 0.6, 1.0, 1.3]  # in SEARCH_TURN_RAD, from the pose last searched whole
    whole = []
    for turn in turns:
        believed.odometry = Pose(2.0, 0.0, turn * SEARCH_TURN_RAD)
        whole.append(search.regions(W, H) is None)
    assert whole == [False, False, False, True]


def test_every_frame_is_searched_whole_while_the_robot_is_lost():
    believed = Believed(Pose(2.0, 0.0, 0.0))
    search = searched(believed)
    believed.found = False
    assert all(search.regions(W, H) is None for _ in range(5))


def test_regions_over_most_of_the_frame_are_searched_as_the_whole_frame():
    # Bands the whole height of the frame (no heights), half as wide as it or more.
    believed = Believed(Pose(2.0, 0.0, 0.0))
    search = searched(believed, Building(walls=WALLS))
    believed.sigma_heading = math.radians(20)
    assert search.regions(W, H) is None


def test_a_marker_found_is_followed_by_the_odometry_where_the_estimate_is_wrong():
    # The estimate has the robot a metre off and facing away: no prediction of marker 7.
    # Found in the whole frame, it is looked for again where the odometry's turn and
    # step since have carried it.
    before, after = TruePose(2.0, 0.5, 0.2), TruePose(2.05, 0.49, 0.2 + 0.7 * SEARCH_TURN_RAD)
    believed = Believed(Pose(1.0, -0.5, math.pi))
    believed.odometry = Pose(before.x, before.y, before.heading)
    search = MarkerSearch(believed, DETECTOR, BUILDING)  # type: ignore[arg-type]
    assert search.regions(W, H) is None
    grey = cv2.cvtColor(CAMERA.render(before, W, H), cv2.COLOR_BGR2GRAY)
    search.seen(DETECTOR.detect(grey))
    believed.odometry = Pose(after.x, after.y, after.heading)
    regions = search.regions(W, H)
    # Some 50 pixels to the left of where it was, more than the margin round it.
    assert regions is not None and holds(regions, square(after))


def test_a_marker_predicted_but_not_found_waits_for_the_next_search_unless_it_grows():
    # Something the plan does not know hides marker 7: it is looked for once, then not
    # again until it would look larger (the robot comes nearer).
    believed = Believed(Pose(0.0, 0.0, 0.0))
    search = searched(believed, search_every=100)
    assert search.regions(W, H)
    search.seen([])
    assert search.regions(W, H) == []
    search.seen([])
    believed.pose = believed.odometry = Pose(0.2, 0.0, 0.0)  # 4 % nearer: no
    assert search.regions(W, H) == []
    search.seen([])
    believed.pose = believed.odometry = Pose(1.0, 0.0, 0.0)  # a fifth nearer
    assert search.regions(W, H)


def test_an_uncalibrated_camera_is_searched_whole_every_frame():
    detector = MarkerDetector("apriltag_36h11", 0.16, ids=[7])
    search = MarkerSearch(Believed(Pose(2.0, 0.0, 0.0)), detector, BUILDING)  # type: ignore[arg-type]
    assert all(search.regions(W, H) is None for _ in range(5))
