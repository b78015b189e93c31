"""A simulated board in a floor plan's building: what `--sim` drives in (§3.2.2).

The thesis's simulator computed "only the motor odometry ... not the Giraff's resulting
position in space"; this one also knows where the robot really is, and here it is put
in the building the console plans on: it starts at the plan's start room, the plan's
closed doors and anything the operator blocks are obstacles, which the simulated range
finder (standing in for the one §6 recommends adding) reports and the synthetic camera
shows. The console never reads the true pose; only this module, the camera and the
tests do.

It sits above both the simulator and the console's planning layer, as the command line
does: the simulator itself knows nothing of floor plans.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from giraff_console.camera.markers import Region
from giraff_console.camera.processors import CameraIntrinsics
from giraff_console.camera.source import CameraSource, Frame, SyntheticCamera
from giraff_console.clock import Clock
from giraff_console.planning.floorplan import FloorPlan
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.planning.landmarks import aruco_dictionary, marker_detector
from giraff_console.planning.route_planner import ROBOT_RADIUS_M, walls_of
from giraff_console.planning.walls import WallSegment, doorway, wall_segments
from giraff_console.robot.localisation import Localisation
from giraff_console.robot.marker_eye import EYE_FPS, EYE_SIZE, MarkerEye
from giraff_console.robot.marker_search import Building
from giraff_console.robot.odometry import Pose
from giraff_console.sim.board import GiraffBoard
from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
from giraff_console.sim.collision import Solids, grid_edges
from giraff_console.sim.drive import TruePose
from giraff_console.sim.lidar import LidarWorld
from giraff_console.sim.marker_windows import MarkerWindows
from giraff_console.sim.range_finder import SimRangeFinder
from giraff_console.sim.surroundings import Surroundings
from giraff_console.sim.world import (
    DOOR_FRAME,
    POSTER_WIDTH,
    WALL,
    Wall,
    World,
    WorldMarker,
    marker_pattern,
)

# The simulated range finder: how far it sees, and how wide.
SENSING_RANGE_M = 1.5
SENSING_FOV_DEG = 70.0


class SimulatedSite:
    """The board, placed in the building, with its obstacles and range finder."""

    def __init__(self, board: GiraffBoard, plan: FloorPlan, start: Pose | None,
                 sensing_range: float = SENSING_RANGE_M,
                 robot_radius: float = ROBOT_RADIUS_M) -> None:  # fmt: skip
        self.board = board
        self.plan = plan
        if start is not None:
            # The robot starts on its dock: the start room's point and heading, where it
            # charges on later firmware (issue 13).
            board.dock = TruePose(start.x, start.y, start.heading)
            board.place(board.dock)
        # The plan's own grid, if it has one: where a plan without outlines has its walls.
        self._grid = walls_of(plan) if plan.grid is not None else None
        self.surroundings = shut_doors(plan, self._grid)
        # The building is solid: a robot of `robot_radius` that drives into a wall stops
        # against it, wheels stalled (sim/collision.py). The walls are the ones the
        # camera sees (building_walls). Closed doors and boxes are the surroundings',
        # which open and move.
        walls = building_walls(plan, self._grid)
        board.make_solid(Solids([(wall.a, wall.b) for wall in walls], robot_radius,
                                self.surroundings))  # fmt: skip
        self.range_finder = SimRangeFinder(
            lambda: board.true_pose, self.surroundings, sensing_range, SENSING_FOV_DEG
        )
        # The camera's world from the plan itself, as runtime/robot.py draws a building whose
        # markers moved: a plan without outlines has its grid read a second time, once.
        self.world = plan_world(plan)
        self._doors = {door.id: door for door in plan.doors}

    @property
    def caster_drift(self) -> float:
        """The most the simulated robot's casters turn it after a turn on the spot,
        radians: the thesis's 45 degrees with --imperfect, none on the ideal board."""
        return math.radians(self.board.config.imperfections.caster_drift_deg)

    def true_pose(self) -> Pose:
        pose = self.board.true_pose
        return Pose(pose.x, pose.y, pose.heading)

    def camera(self, clock: Clock) -> tuple[SyntheticCamera, WorldCamera]:
        """The synthetic camera on the robot as it really stands, its frames stamped by
        `clock` (the control loop's: a frame's time is what moves its markers to the
        present, robot/localisation.py), and the world camera that draws them."""
        world_camera = WorldCamera(self.world, surroundings=self.surroundings)
        board = self.board
        source = SyntheticCamera(
            lambda width, height: world_camera.render(board.true_pose, width, height),
            clock.now,
        )
        return source, world_camera

    def eye(self, localisation: Localisation, clock: Clock, *, fps: float = EYE_FPS,
            size: tuple[int, int] = EYE_SIZE,
            whole_frames: bool = False) -> MarkerEye | None:  # fmt: skip
        """The synthetic camera as the localisation's eye, without a screen; None when
        the plan has no markers to see.

        Nobody sees its frames but the eye, so the camera draws only round the markers
        (sim/marker_windows.py); `whole_frames` has it draw all of every frame and the
        eye look through all of it, as before issue 25 (bench/sim_speed.py's baseline)."""
        landmarks = self.plan.landmarks
        if landmarks is None:
            return None
        whole, world_camera = self.camera(clock)
        board = self.board
        source: CameraSource = (
            whole if whole_frames
            else _EyeCamera(MarkerWindows(world_camera), lambda: board.true_pose, clock.now)
        )  # fmt: skip

        def intrinsics(width: int, height: int) -> CameraIntrinsics:
            # The simulator's class, field for field; the console has its own.
            known = world_camera.intrinsics(width, height)
            return CameraIntrinsics(known.fx, known.fy, known.cx, known.cy, known.distortion)

        detector = marker_detector(landmarks, intrinsics)
        # What the console knows besides: the plan's walls and markers' heights, and the
        # camera's height as its mount would be measured (as the intrinsics are given).
        walls = building_walls(self.plan, self._grid)
        building = Building(
            CAMERA_HEIGHT_M, {marker.id: marker.height for marker in landmarks.markers},
            np.array([(wall.a, wall.b) for wall in walls], dtype=float).reshape(-1, 2, 2),
        )  # fmt: skip
        return MarkerEye(source, detector, localisation, clock, fps=fps, size=size,
                         building=building, whole_frames=whole_frames)  # fmt: skip

    def lidar_world(self) -> LidarWorld:
        """What a lidar on the simulated robot sees: the building's walls (those the
        robot stops against, grid-drawn furniture included on a plan without outlines)
        and the surroundings, from the robot's true pose."""
        board = self.board
        walls = [(wall.a, wall.b) for wall in building_walls(self.plan, self._grid)]
        return LidarWorld(lambda: board.true_pose, walls, self.surroundings)

    def close_door(self, door_id: str) -> None:
        """Shut a door of the plan in the simulated building (KeyError if none)."""
        door = self._doors[door_id]
        self.surroundings.close_door(door_id, *doorway(self.plan, door, self._grid))

    def open_door(self, door_id: str) -> None:
        self.surroundings.open_door(door_id)

    def block(self, x: float, y: float) -> str:
        """A 0.5 m box in the robot's way at (x, y) metres; its id."""
        return self.surroundings.block(x, y)

    def unblock(self, x: float, y: float) -> list[str]:
        """Take away the box at (x, y), or the nearest within 0.5 m; the ids taken."""
        return self.surroundings.unblock(x, y)


def shut_doors(plan: FloorPlan, grid: OccupancyGrid | None) -> Surroundings:
    """The building's surroundings as the plan leaves them: its shut doors shut, nothing
    else put down. `grid` is the plan's, if it has one."""
    surroundings = Surroundings()
    for door in plan.doors:
        if not door.open:
            surroundings.close_door(door.id, *doorway(plan, door, grid))
    return surroundings


class _EyeCamera:
    """The synthetic camera as the eye alone sees it: drawn only round the markers
    (sim/marker_windows.py), and only in the regions the eye reads out
    (robot/marker_eye.py, RegionReadout)."""

    name = "synthetic camera"

    def __init__(self, windows: MarkerWindows, pose: Callable[[], TruePose],
                 clock: Callable[[], float]) -> None:  # fmt: skip
        self.windows = windows
        self.pose = pose
        self.clock = clock
        self._size = EYE_SIZE
        # The last picture and what it was drawn for: a robot standing still is shown
        # the same one again rather than drawn anew ten times a second (issue 26).
        self._drawn: tuple[object, np.ndarray] | None = None
        self.drawings = 0

    def open(self, width: int, height: int) -> tuple[int, int]:
        self._size = (width, height)
        return self._size

    def read(self) -> Frame | None:
        return self._read(None)

    def read_regions(self, regions: Sequence[Region]) -> Frame | None:
        return self._read([(r.left, r.top, r.right, r.bottom) for r in regions])

    def _read(self, wanted: list[tuple[int, int, int, int]] | None) -> Frame:
        # Stamped when the view is taken, as SyntheticCamera's frames are.
        captured_at = self.clock()
        pose, surroundings = self.pose(), self.windows.camera.surroundings
        revision = surroundings.snapshot().revision if surroundings is not None else None
        drawn_for = (pose, self._size, wanted, revision)
        if self._drawn is None or self._drawn[0] != drawn_for:
            picture = self.windows.render(pose, *self._size, wanted)
            picture.flags.writeable = False  # shared by the frames that show it again
            self._drawn = (drawn_for, picture)
            self.drawings += 1
        return Frame(self._drawn[1], captured_at)

    def close(self) -> None:
        pass


def building_walls(plan: FloorPlan, grid: OccupancyGrid | None = None) -> list[WallSegment]:
    """The building's fixed walls, which the simulated robot stops against and the
    synthetic camera sees: the edges of the rooms' outlines, cut at the doorways (shut
    doors are the surroundings', which can open them).

    A plan without outlines (an RMF import, or points and doors over a scan) has its
    walls in its grid, where the robot plans: the edges round the grid's occupied cells,
    runs merged (sim/collision.py's grid_edges). The camera then shows the scanned walls
    where the robot finds them, rather than an empty floor through which it bumps into
    things it cannot see. Unknown cells stay open here, as unmapped space does to a real
    robot; the planner keeps out of them. A plan with neither outlines nor a grid is an
    open floor, with no walls. `grid` is the plan's, if it has been read already."""
    if any(room.outline for room in plan.rooms.values()) or plan.grid is None:
        return [wall for wall in wall_segments(plan) if wall.kind != "door"]
    grid = grid if grid is not None else walls_of(plan)
    assert grid is not None
    edges = grid_edges(grid.cells == OCCUPIED, grid.resolution, grid.origin)
    return [WallSegment(a, b) for a, b in edges]


def plan_world(plan: FloorPlan) -> World:
    """The building as the synthetic camera sees it: its walls (building_walls), door
    frames dark, a poster half-way along every wall long enough to hang one, and the
    plan's markers where it says they hang, each with its true pattern from cv2.aruco
    (issue 14)."""
    kinds = {"wall": WALL, "frame": DOOR_FRAME, "door": DOOR_FRAME}
    seen = []
    for segment in building_walls(plan):
        if segment.kind == "door":
            continue  # shut doors are the surroundings', which can open them
        (ax, ay), (bx, by) = segment.a, segment.b
        poster = (segment.length - POSTER_WIDTH) / 2 if segment.length > 2.0 else math.nan
        seen.append(Wall(ax, ay, bx, by, kinds[segment.kind], poster))
    markers = []
    landmarks = plan.landmarks
    if landmarks is not None:
        dictionary = aruco_dictionary(landmarks.family)
        for marker in landmarks.markers:
            markers.append(
                WorldMarker(
                    marker.id, marker.at[0], marker.at[1], marker.height,
                    math.radians(marker.facing), landmarks.size,
                    marker_pattern(dictionary, marker.id),
                )
            )  # fmt: skip
    return World(seen, markers)
