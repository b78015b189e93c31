"""What a front end asks of the robot, as one typed value: which board, which building,
which camera, and, in the simulated building, what is different about it.

The command line (cli/options.py) fills it in from its options; the composition root
(runtime/robot.py) builds the robot from it and the settings file. A mistake in it is
a UsageError, which every command reports the same way (exit code 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from giraff_console.camera.feed import DEFAULT_FPS
from giraff_console.camera.processors import FAST_THRESHOLD
from giraff_console.missions.docking import DOCK
from giraff_console.planning.floorplan import FloorPlan, Landmarks, load_floorplan
from giraff_console.planning.landmarks import fit_on_walls, marker_walls
from giraff_console.robot.odometry import Pose


class UsageError(Exception):
    """A mistake in what was asked: an option, the floor plan, a room; exit code 2."""


@dataclass(frozen=True)
class RobotOptions:
    """The robot asked for. `screen`: a person watches it (the console in its own
    process, the daemon for its consoles): the camera's pictures are drawn, and the
    simulator runs in real time unless `sim_speed` says otherwise. Without it (`go`,
    `patrol`, `survey`), the simulator runs on a virtual clock stepped `sim_speed` times
    faster than real time and looks for markers on the loop's thread, so that a run
    repeats exactly whatever the speed (headless, in cli/)."""

    port: str | None = None  # None: the built-in simulator
    floorplan: Path | None = None  # None: the example care home
    routes: Path | None = None
    recordings: Path | None = None
    at: str | None = None  # ROOM[:DEG]: where a real robot stands, said by the operator
    camera: str | None = None
    calibration: str | None = None
    fast_threshold: int = FAST_THRESHOLD
    camera_fps: float = DEFAULT_FPS
    landmarks: bool = True  # False: dead reckoning alone (--no-landmarks)
    screen: bool = False
    # The daemon: its consoles in other processes watch the camera (service/daemon.py).
    shares_camera: bool = False
    # Markers to be found afresh by a survey (their family and size; none known yet).
    surveying: Landmarks | None = None
    # A board-like pseudo-terminal for another program, a client of the service (§4.5).
    virtual_port: bool = False
    # The simulator's.
    firmware: str | None = None
    sim_speed: float = 1.0
    imperfect_seed: int | None = None
    faults: bool = True
    blocks: tuple[str, ...] = ()
    sim_start: str | None = None
    move_markers: tuple[str, ...] = ()
    sim_markers: Path | None = None
    # The building the simulated robot is in, when it is not the console's plan: one the
    # console is to map (issue 29), or the real building behind a plan made from a map.
    sim_building: Path | None = None
    eye_fps: float | None = None
    eye_size: str | None = None
    # The lidar (lidar/): a port or URL; SIMULATED_LIDAR (lidar/__init__.py) for the
    # simulator's own with --sim, the settings' port on a real robot; None: the
    # settings' port on a real robot, none with the simulator.
    lidar: str | None = None

    @property
    def simulated(self) -> bool:
        return self.port is None

    def simulator_only(self) -> list[str]:
        """The options given that mean something only in the simulated building."""
        given = {
            "--imperfect": self.imperfect_seed is not None, "--block": bool(self.blocks),
            "--sim-start": self.sim_start is not None,
            "--move-marker": bool(self.move_markers),
            "--sim-markers": self.sim_markers is not None,
            "--sim-building": self.sim_building is not None, "--eye-fps": self.eye_fps is not None,
            "--eye-size": self.eye_size is not None,
            "--firmware": self.firmware is not None,
        }  # fmt: skip
        return [name for name, there in given.items() if there]


def placed_at(plan: FloorPlan, text: str) -> Pose:
    """The pose `--at ROOM[:DEG]` says: the room's point (the start room's for `dock`),
    facing DEG or the room's heading. UsageError if there is no such room, or neither
    gives a heading."""
    name, _, degrees = text.partition(":")
    room = plan.rooms.get(plan.start if name == DOCK and plan.start is not None else name)
    if room is None:
        raise UsageError(f"--at: {plan.no_room(name, also=[DOCK] if plan.start else [])}")
    try:
        heading = finite(float(degrees)) if degrees else room.heading
    except ValueError:
        raise UsageError(f"--at wants ROOM or ROOM:DEGREES, not {text!r}") from None
    if heading is None:
        raise UsageError(f"--at {name}: the room has no heading; say which way the robot "
                         f"faces: --at {name}:DEGREES")  # fmt: skip
    return Pose(room.at[0], room.at[1], math.radians(heading))


def hung_markers(plan: FloorPlan, path: Path | None) -> FloorPlan | None:
    """The plan with the markers of the floor plan at `path` (`--sim-markers`), for the
    simulated building; None without one. FloorPlanError for a plan that cannot be read,
    ValueError for one without markers."""
    if path is None:
        return None
    other = load_floorplan(path)
    if other.landmarks is None or not other.landmarks.markers:
        raise ValueError(f"--sim-markers {path}: the floor plan has no markers to hang")
    return replace(plan, landmarks=other.landmarks)


def moved_plan(plan: FloorPlan, moves: tuple[str, ...]) -> FloorPlan | None:
    """A copy of the plan with markers slid along their walls (`ID:DX`), for the
    simulated building; None without moves. ValueError for a bad move."""
    if not moves:
        return None
    landmarks = plan.landmarks
    if landmarks is None:
        raise ValueError("--move-marker: the floor plan has no markers")
    markers = {marker.id: marker for marker in landmarks.markers}
    walls = marker_walls(plan)
    for text in moves:
        marker_id, along = _move(text)
        if marker_id not in markers:
            raise ValueError(f"--move-marker: the floor plan has no marker {marker_id}")
        marker = markers[marker_id]
        # Along the wall is square to the marker's facing; +90° is the marker's own
        # left, the right of someone standing in front of it.
        angle = math.radians(marker.facing + 90.0)
        at = (marker.at[0] + along * math.cos(angle), marker.at[1] + along * math.sin(angle))
        if fit_on_walls(at, marker.facing, walls).wall is None:
            raise ValueError(f"--move-marker {text}: marker {marker_id} would slide off its "
                             f"wall, to ({at[0]:.2f}, {at[1]:.2f})")  # fmt: skip
        markers[marker_id] = replace(marker, at=at)
    moved = tuple(markers[marker.id] for marker in landmarks.markers)
    return replace(plan, landmarks=replace(landmarks, markers=moved))


def _move(text: str) -> tuple[int, float]:
    try:
        marker_id, along = text.split(":")
        return int(marker_id), finite(float(along))
    except ValueError:
        raise ValueError(f"--move-marker wants ID:DX (metres), not {text!r}") from None


def frame_size(text: str) -> tuple[int, int]:
    """`--eye-size WxH`; ValueError for anything else."""
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--eye-size wants WxH in pixels, not {text!r}") from None
    if not (16 <= width <= 4096 and 16 <= height <= 4096):
        raise ValueError(f"--eye-size wants 16 to 4096 pixels a side, not {text!r}")
    return width, height


def point(text: str) -> tuple[float, float]:
    """`--block X,Y`; ValueError for anything else."""
    try:
        x, y = (finite(float(part)) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--block wants X,Y in metres, not {text!r}") from None
    return x, y


def finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("not finite")
    return value
