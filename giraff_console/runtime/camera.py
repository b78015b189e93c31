"""The camera as every front end opens it: the console for its screen and its markers, and
the daemon, `go` and `patrol` on a real robot for their markers alone (issue 25: the
daemon finds the robot by the plan's markers through the robot's real camera, as the
console does). Also the simulated building's camera for `sim --camera`, which serves it
to a console in another process.
"""

from __future__ import annotations

import os

import serial

from giraff_console.camera.feed import DEFAULT_FPS, CameraFeed
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.markers import MarkerDetector
from giraff_console.camera.processors import (
    FAST_THRESHOLD,
    CameraIntrinsics,
    CannyEdges,
    FastCorners,
    FrameProcessor,
    Pipeline,
    Undistortion,
)
from giraff_console.camera.source import DEFAULT_RESOLUTION, Frame, SyntheticCamera, open_camera
from giraff_console.clock import Clock, RealClock
from giraff_console.planning.floorplan import FloorPlan, Landmarks
from giraff_console.planning.landmarks import marker_beliefs, marker_detector
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.marker_eye import EYE_FPS, hand_on
from giraff_console.runtime.sim_site import plan_world, shut_doors
from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.pose_view import PoseView
from giraff_console.sim.surroundings import Surroundings
from giraff_console.sim.world import World, demo_world


def camera_feed(
    device: str | None,
    simulator: serial.SerialBase | None,
    calibration: str | None = None,
    fast_threshold: int = FAST_THRESHOLD,
    fps: float = DEFAULT_FPS,
    world: World | None = None,
    surroundings: Surroundings | None = None,
    landmarks: Landmarks | None = None,
    clock: Clock | None = None,
) -> CameraFeed:
    """The camera asked for, else the synthetic one with the simulator (seeing `world`,
    or a demo world, and `surroundings`, its frames stamped by `clock`, the control
    loop's), else camera 0; a test pattern when none of them is there (§3.4.1). With
    `landmarks`, the marker detector runs on EYE_FPS frames a second, shown or not, for
    the localisation (see `find_the_robot`); `o` shows what it finds, on every frame."""
    now = (clock or RealClock()).now
    synthetic = None
    camera_world = None
    if simulator is not None:
        camera_world = WorldCamera(world or demo_world(), surroundings=surroundings)
        board = simulator.board
        # Drawn again only when the robot, the picture's size or the surroundings have
        # moved: standing still, it sees the same picture (sim/pose_view.py, issue 26).
        synthetic = SyntheticCamera(PoseView(camera_world, lambda: board.true_pose), now)
    if device is None and synthetic is None:
        device = "0"
    source, size, note = open_camera(device, *DEFAULT_RESOLUTION, synthetic, now)
    undistortion = Undistortion.from_file(calibration) if calibration else None
    processors: list[FrameProcessor] = [FastCorners(fast_threshold), CannyEdges()]

    def intrinsics(width: int, height: int) -> CameraIntrinsics | None:
        """The intrinsics of the frames the processors see: a calibrated camera's after
        undistortion, the synthetic camera's exactly, else unknown (markers are then
        outlined but not placed)."""
        if undistortion is not None:
            return undistortion.intrinsics(width, height)
        if camera_world is not None and feed.source is synthetic:
            known = camera_world.intrinsics(width, height)
            return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy, known.distortion)
        return None

    if landmarks is not None:
        processors.append(marker_detector(landmarks, intrinsics))
    pipeline = Pipeline(processors, undistortion)
    pipeline.toggle("fast")
    if landmarks is not None:
        # At the rate the localisation needs, whatever the camera's (--camera-fps): a
        # faster camera makes a smoother picture, not a better fix (robot/marker_eye.py).
        pipeline.require("markers", EYE_FPS)
    truecolor = os.environ.get("COLORTERM") in ("truecolor", "24bit")
    feed = CameraFeed(
        source, size, pipeline, HalfBlockRenderer(truecolor), lambda picture: None, fps
    )
    feed.note = note
    return feed


def find_the_robot(control: ControlLoop, camera: CameraFeed, plan: FloorPlan,
                   surveying: bool = False) -> str | None:  # fmt: skip
    """Let the plan's markers, as the camera finds them, correct where the robot is
    believed to be (robot/localisation.py), or, `surveying`, every marker of their
    family be mapped (missions/survey.py); a note for the status log, also when the
    camera cannot place them. Only the live camera's frames count: a recording played
    back shows where the robot was then, not where it is."""
    markers = marker_beliefs(plan)
    detector = camera.pipeline.processors.get("markers")
    if not (markers or surveying) or not isinstance(detector, MarkerDetector):
        return None
    if detector.intrinsics(*camera.size) is None:
        # Markers the console cannot place would leave every mission looking for one.
        return ("markers: this camera has no calibration (--calibration), so markers are "
                "outlined but not placed")  # fmt: skip
    control.localisation.use_markers(markers, detector.size)
    live, hand = camera.source, hand_on(control.localisation)

    def listener(frame: Frame, data: dict[str, object]) -> None:
        if camera.source is live:
            hand(frame, data)

    camera.listeners.append(listener)
    if surveying:
        return f"markers: mapping every {detector.family} marker the camera sees"
    return f"markers: finding the robot by the plan's {len(markers)} markers"


def plan_camera(plan: FloorPlan) -> WorldCamera:
    """The camera of the plan's building, its shut doors shut, as the console's own
    simulator sees it (runtime/sim_site.py)."""
    grid = walls_of(plan) if plan.grid is not None else None
    return WorldCamera(plan_world(plan), surroundings=shut_doors(plan, grid))
