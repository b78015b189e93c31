"""The marker eye without a screen (issue 25): a frame with nothing to look for is not
taken, a camera that reads out regions is asked for them alone, a marker no prediction
expects is still found by the next whole search, and `whole_frames` looks as before."""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from giraff_console.camera.markers import CameraIntrinsics, MarkerDetector, Region
from giraff_console.camera.source import Frame
from giraff_console.clock import VirtualClock
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.marker_eye import MarkerEye
from giraff_console.robot.marker_search import Building
from giraff_console.robot.odometry import Pose
from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.marker_windows import MarkerWindows
from giraff_console.sim.world import Wall, World, WorldMarker, marker_pattern

W, H = 800, 600
FPS = 10.0
DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
ROOM = [Wall(-5, -5, 5, -5), Wall(5, -5, 5, 5), Wall(5, 5, -5, 5), Wall(-5, 5, -5, -5)]
SEVEN = WorldMarker(7, 5.0, 0.0, 1.1, math.pi, 0.16, marker_pattern(DICTIONARY, 7))
CAMERA = WorldCamera(World(ROOM, [SEVEN]))
BUILDING = Building(CAMERA_HEIGHT_M, {7: 1.1},
                    np.array([((w.x1, w.y1), (w.x2, w.y2)) for w in ROOM]))  # fmt: skip


def intrinsics(width: int, height: int) -> CameraIntrinsics:
    known = CAMERA.intrinsics(width, height)
    return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy)


class Localised:
    """The localisation as the eye sees it: the plan's markers, an estimate (the true
    pose, well known) and the sightings handed on, frame by frame."""

    def __init__(self, pose: TruePose, markers: dict[int, Pose] | None = None) -> None:
        self.markers = {7: Pose(5.0, 0.0, math.pi)} if markers is None else markers
        self.pose = Pose(pose.x, pose.y, pose.heading)
        self.frames: list[list[int]] = []

    def estimate(self) -> Estimate:
        s, h = 0.02, math.radians(1)
        return Estimate(self.pose, self.pose, ((s * s, 0, 0), (0, s * s, 0), (0, 0, h * h)),
                        s, h, (s, s, 0.0), landmarks=True, found=True)  # fmt: skip

    def sighted(self, sightings) -> None:
        self.frames.append([s.marker_id for s in sightings])


class Camera:
    """The synthetic camera at a pose, drawn round the markers; it counts what it is
    asked for, and reads out regions if `regions` (RegionReadout)."""

    name = "test camera"

    def __init__(self, pose: TruePose, clock: VirtualClock, world: World | None = None) -> None:
        self.windows = MarkerWindows(CAMERA if world is None else WorldCamera(world))
        self.pose, self.clock = pose, clock
        self.reads = 0

    def open(self, width: int, height: int) -> tuple[int, int]:
        return width, height

    def read(self) -> Frame | None:
        self.reads += 1
        return Frame(self.windows.render(self.pose, W, H), self.clock.now())

    def close(self) -> None:
        pass


class RegionCamera(Camera):
    def __init__(self, pose: TruePose, clock: VirtualClock) -> None:
        super().__init__(pose, clock)
        self.asked: list[list[Region]] = []

    def read_regions(self, regions: Sequence[Region]) -> Frame | None:
        self.asked.append(list(regions))
        wanted = [(r.left, r.top, r.right, r.bottom) for r in regions]
        return Frame(self.windows.render(self.pose, W, H, wanted), self.clock.now())


def eye_for(camera: Camera, localised: Localised, clock: VirtualClock, **kwargs) -> MarkerEye:
    detector = MarkerDetector("apriltag_36h11", 0.16, intrinsics, ids=[7])
    return MarkerEye(camera, detector, localised, clock, fps=FPS, size=(W, H),  # type: ignore[arg-type]
                     building=BUILDING, **kwargs)  # fmt: skip


def looks(eye: MarkerEye, clock: VirtualClock, frames: int) -> None:
    for _ in range(frames):
        eye.look()
        clock.advance(1 / FPS)


def test_a_frame_with_nothing_to_look_for_is_not_taken():
    clock = VirtualClock()
    facing_away = TruePose(2.0, 0.0, math.pi)
    camera = Camera(facing_away, clock)
    eye = eye_for(camera, Localised(facing_away), clock)
    looks(eye, clock, 4)
    assert camera.reads == 1  # the first frame, searched whole
    assert eye.cost()["untaken_frames"] == 3


def test_a_camera_that_reads_out_regions_is_asked_for_them_alone():
    clock = VirtualClock()
    pose = TruePose(2.0, 0.3, 0.1)
    camera = RegionCamera(pose, clock)
    localised = Localised(pose)
    eye = eye_for(camera, localised, clock)
    looks(eye, clock, 3)
    assert camera.reads == 1 and len(camera.asked) == 2
    assert all(sum(r.area for r in regions) < 0.05 * W * H for regions in camera.asked)
    assert localised.frames == [[7], [7], [7]]


def test_the_eye_finds_the_same_markers_as_looking_through_every_whole_frame():
    seen = {}
    for whole in (False, True):
        clock = VirtualClock()
        camera = RegionCamera(TruePose(0.0, 0.0, 0.0), clock)
        localised = Localised(camera.pose)
        eye = eye_for(camera, localised, clock, whole_frames=whole)
        for step in range(30):  # a walk towards the marker, swaying, looking a little aside
            sway, look = 0.4 * math.sin(step / 5), 0.05 * math.cos(step / 3)
            camera.pose = TruePose(1.5 + 0.07 * step, sway, look)
            localised.pose = Pose(camera.pose.x + 0.01, camera.pose.y, camera.pose.heading)
            looks(eye, clock, 1)
        seen[whole] = localised.frames
    assert seen[False] == seen[True] and sum(map(len, seen[True])) == 30


def test_a_marker_the_plan_does_not_expect_is_found_by_the_next_whole_search():
    # The plan has marker 7 at the room's other end; the robot looks at where it really
    # hangs, from the first frame on. Found in the first frame (searched whole), then
    # tracked; hidden for a frame, then seen again: found again by the next search.
    clock = VirtualClock()
    pose = TruePose(2.0, 0.0, 0.0)
    camera = Camera(pose, clock)
    localised = Localised(pose, {7: Pose(-5.0, 0.0, 0.0)})
    eye = eye_for(camera, localised, clock)
    looks(eye, clock, 3)
    camera.windows = MarkerWindows(WorldCamera(World(ROOM)))  # someone stands in front of it
    looks(eye, clock, 1)
    camera.windows = MarkerWindows(CAMERA)
    looks(eye, clock, 12)
    found = [bool(frame) for frame in localised.frames]
    assert found[:5] == [True, True, True, False, True]
    # Frames 4 to 9 had nothing to look for; frame 10, a second after the first, was
    # searched whole, and the marker tracked from there.
    cost = eye.cost()
    assert (cost["untaken_frames"], cost["whole_frames"], cost["frames"]) == (6, 2, 10)


def test_whole_frames_takes_every_frame_and_looks_through_all_of_it():
    clock = VirtualClock()
    facing_away = TruePose(2.0, 0.0, math.pi)
    camera = Camera(facing_away, clock)
    eye = eye_for(camera, Localised(facing_away), clock, whole_frames=True)
    looks(eye, clock, 4)
    assert camera.reads == 4
    assert (eye.cost()["whole_frames"], eye.cost()["untaken_frames"]) == (4, 0)
