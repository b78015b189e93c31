"""Markers on the simulated walls, seen by the synthetic camera and found by OpenCV (issue 14).

The camera draws each marker from its true cells at its size, height and facing; the
console's detector (camera/markers.py) must then find it in the pixels alone and tell
its distance and bearing as the geometry has them, and must not see one the camera
cannot: behind it, behind a wall, behind a closed door, or from the back of its wall.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector
from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import Surroundings
from giraff_console.sim.world import QUIET_ZONE_CELLS, Wall, World, WorldMarker, marker_pattern

FAMILY = "apriltag_36h11"
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
SIZE = 0.16
HEIGHT = 1.1
WIDTH, HEIGHT_PX = 800, 600
# A 10 m square room; marker 7 in the middle of its east wall, looking west into it.
ROOM = [Wall(-5, -5, 5, -5), Wall(5, -5, 5, 5), Wall(5, 5, -5, 5), Wall(-5, 5, -5, -5)]
EAST = WorldMarker(7, 5.0, 0.0, HEIGHT, math.pi, SIZE, marker_pattern(DICTIONARY, 7))


def marker(marker_id: int, x: float, y: float, facing_deg: float) -> WorldMarker:
    pattern = marker_pattern(DICTIONARY, marker_id)
    return WorldMarker(marker_id, x, y, HEIGHT, math.radians(facing_deg), SIZE, pattern)


def detector_for(camera: WorldCamera) -> MarkerDetector:
    def intrinsics(width: int, height: int) -> CameraIntrinsics:
        # The simulator's class, field for field; the console has its own.
        known = camera.intrinsics(width, height)
        return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy, known.distortion)

    return MarkerDetector(FAMILY, SIZE, intrinsics)


def seen(camera: WorldCamera, pose: TruePose):
    image = camera.render(pose, WIDTH, HEIGHT_PX)
    return detector_for(camera).detect(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), 12.5)


def wrapped(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def test_a_pattern_is_the_marker_s_cells_with_its_border():
    pattern = marker_pattern(DICTIONARY, 7)
    assert pattern.shape == (8, 8) and pattern.dtype == bool
    assert not pattern[0].any() and not pattern[-1].any()  # the black border
    assert not pattern[:, 0].any() and not pattern[:, -1].any()
    assert pattern[1:-1, 1:-1].any()
    assert not np.array_equal(pattern, marker_pattern(DICTIONARY, 8))
    with pytest.raises(ValueError):
        WorldMarker(1, 0, 0, 1, 0, 0.0, pattern)
    with pytest.raises(ValueError):
        World(ROOM, [EAST, marker(7, -5.0, 0.0, 0)])  # an id is unique


@pytest.mark.parametrize("distance", [1.0, 1.5, 2.0, 2.5, 3.0])
@pytest.mark.parametrize(
    ("slant_deg", "turn_deg"),
    [(0, 0), (0, 25), (30, -12), (-30, 20), (45, 0), (-45, -15)],
)
def test_the_detector_finds_the_marker_and_its_true_distance_and_bearing(
    distance, slant_deg, turn_deg
):
    """The robot `distance` m from the marker, `slant_deg` off its normal, its heading
    `turn_deg` away from the marker, so that the marker sits off the picture's centre."""
    slant = math.radians(slant_deg)
    x = EAST.x - distance * math.cos(slant)
    y = EAST.y + distance * math.sin(slant)
    towards = math.atan2(EAST.y - y, EAST.x - x)
    pose = TruePose(x, y, towards + math.radians(turn_deg))
    camera = WorldCamera(World(ROOM, [EAST]))
    [sighting] = seen(camera, pose)
    assert sighting.id == 7 and sighting.frame_time == 12.5
    assert sighting.distance_m == pytest.approx(distance, abs=0.03)
    assert math.degrees(abs(wrapped(sighting.bearing_rad + math.radians(turn_deg)))) <= 1.0
    # The facing is the weakest of the three (a small square can look tilted either
    # way): within a few degrees out to 3 m.
    facing = wrapped(EAST.facing - pose.heading)
    assert math.degrees(abs(wrapped(sighting.facing_rad - facing))) <= 5.0
    assert sighting.reprojection_px < 0.5


def test_the_corners_are_where_the_pinhole_puts_them():
    """The camera's intrinsics are exactly what it renders with: the black square's
    corners, projected with them, are where the detector finds them."""
    camera = WorldCamera(World(ROOM, [EAST]))
    pose = TruePose(3.2, 0.37, 0.1)
    [sighting] = seen(camera, pose)
    known = camera.intrinsics(WIDTH, HEIGHT_PX)
    half = SIZE / 2
    expected = []
    for across, up in [(-half, half), (half, half), (half, -half), (-half, -half)]:
        # The marker's face looks along -x: to the right of someone facing it is -y.
        wx, wy, wz = EAST.x, EAST.y - across, HEIGHT + up
        ahead = (wx - pose.x) * math.cos(pose.heading) + (wy - pose.y) * math.sin(pose.heading)
        left = -(wx - pose.x) * math.sin(pose.heading) + (wy - pose.y) * math.cos(pose.heading)
        below = CAMERA_HEIGHT_M - wz
        expected.append((known.cx - known.fx * left / ahead, known.cy + known.fy * below / ahead))
    assert np.abs(sighting.corners - np.array(expected)).max() < 0.15


def test_each_marker_is_drawn_with_its_own_id_and_the_right_way_up():
    world = World(ROOM, [marker(3, 5.0, -0.6, 180), marker(250, 5.0, 0.6, 180)])
    sightings = seen(WorldCamera(world), TruePose(3.0, 0.0, 0.0))
    by_id = {s.id: s for s in sightings}
    assert set(by_id) == {3, 250}
    # Id 250 hangs to the left (+y) of the robot: a positive bearing.
    assert by_id[250].bearing_rad > 0 > by_id[3].bearing_rad
    for sighting in sightings:
        # The printed marker's top-left corner comes first: nearest the picture's.
        assert np.argmin(sighting.corners.sum(axis=1)) == 0


def page_mask(camera: WorldCamera, pose: TruePose) -> np.ndarray:
    """Which pixels show a marker's page, from the renderer's own bookkeeping."""
    pages = []
    original = camera._markers

    def spy(material, *args):
        found = original(material, *args)
        pages.extend(found)
        return found

    camera._markers = spy
    camera.render(pose, WIDTH, HEIGHT_PX)
    del camera._markers
    mask = np.zeros((HEIGHT_PX, WIDTH), dtype=bool)
    for rows, columns, _ in pages:
        mask[rows, columns] = True
    return mask


def page_pixels(camera: WorldCamera, pose: TruePose) -> int:
    return int(page_mask(camera, pose).sum())


def test_a_marker_behind_the_camera_is_not_seen():
    camera = WorldCamera(World(ROOM, [EAST]))
    facing_it = TruePose(3.0, 0.0, 0.0)
    assert seen(camera, facing_it) and page_pixels(camera, facing_it) > 100
    away = TruePose(3.0, 0.0, math.pi)
    assert seen(camera, away) == [] and page_pixels(camera, away) == 0


def test_a_marker_behind_a_wall_is_not_seen():
    # A partition at x = 4 between the robot and the marker.
    camera = WorldCamera(World([*ROOM, Wall(4.0, -0.6, 4.0, 0.6)], [EAST]))
    assert seen(camera, TruePose(2.0, 0.0, 0.0)) == []
    assert page_pixels(camera, TruePose(2.0, 0.0, 0.0)) == 0
    # Past the partition's end it is in view again.
    assert [s.id for s in seen(camera, TruePose(3.5, -1.5, math.radians(45)))] == [7]


def test_a_marker_is_not_seen_from_behind_its_wall():
    # The east wall seen from outside the room, the marker on its inside.
    world = World([*ROOM, Wall(8, -5, 8, 5)], [EAST])
    camera = WorldCamera(world)
    assert seen(camera, TruePose(7.0, 0.0, math.pi)) == []
    assert page_pixels(camera, TruePose(7.0, 0.0, math.pi)) == 0


def test_a_closed_door_in_front_hides_a_marker():
    things = Surroundings()
    camera = WorldCamera(World(ROOM, [EAST]), surroundings=things)
    pose = TruePose(2.0, 0.0, 0.0)
    assert [s.id for s in seen(camera, pose)] == [7]
    things.close_door("d1", (3.5, -1.0), (3.5, 1.0))
    assert seen(camera, pose) == []
    things.open_door("d1")
    assert [s.id for s in seen(camera, pose)] == [7]


def test_a_marker_hangs_only_on_its_own_wall():
    # A marker 10 cm from the east wall's corner with the north wall: its paper would
    # reach round the corner, but is drawn on the east wall only (the north one runs
    # across its face), and the marker is still found.
    corner = marker(9, 5.0, 4.9, 180)
    camera = WorldCamera(World(ROOM, [corner]))
    pose = TruePose(3.0, 3.5, math.radians(35))
    assert [s.id for s in seen(camera, pose)] == [9]
    columns = np.flatnonzero(page_mask(camera, pose).any(axis=0))
    rays = pose.heading + np.arctan2(WIDTH / 2 - (columns + 0.5), camera.focal(WIDTH))
    hit, _, _ = camera._cast(pose, np.cos(rays), np.sin(rays))
    assert set(hit.tolist()) == {1}  # ROOM[1], the east wall
    assert corner.outer == pytest.approx(SIZE * (8 + 2 * QUIET_ZONE_CELLS) / 8)


def test_markers_keep_the_camera_deterministic_and_leave_other_pixels_alone():
    plain = WorldCamera(World(ROOM))
    marked = WorldCamera(World(ROOM, [EAST]))
    pose = TruePose(2.5, 0.2, 0.05)
    first = marked.render(pose, WIDTH, HEIGHT_PX)
    assert np.array_equal(first, marked.render(pose, WIDTH, HEIGHT_PX))
    changed = np.any(first != plain.render(pose, WIDTH, HEIGHT_PX), axis=2)
    # Only the page differs, and the blur's rim of a pixel round it.
    page = page_mask(marked, pose).astype(np.uint8)
    rim = cv2.dilate(page, np.ones((3, 3), np.uint8)).astype(bool)
    assert changed.any() and not (changed & ~rim).any()
