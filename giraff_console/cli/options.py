"""The options every command that drives shares: which robot and building, where the
routes and recordings are kept, and the simulated building's own (`--imperfect`,
`--sim-start`, ...); and the robot they ask for, as runtime/options.py types it.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

# Light modules only: every command's parser is built with these (cli/main.py).
from giraff_console.camera.defaults import DEFAULT_FPS, EYE_FPS, EYE_SIZE, FAST_THRESHOLD
from giraff_console.cli.simulator_options import add_firmware_option
from giraff_console.data_folders import default_recordings, default_routes
from giraff_console.lidar import SIMULATED_LIDAR

if TYPE_CHECKING:
    from giraff_console.planning.floorplan import Landmarks
    from giraff_console.runtime.options import RobotOptions
    from giraff_console.settings import Settings


def add_board_options(parser: argparse.ArgumentParser, example: Path, *,
                      after_command: bool) -> None:  # fmt: skip
    """The options that say which robot and building: the console's before any command,
    and every command's that drives `after_command` (given there or before it, so their
    defaults are the console's: SUPPRESS keeps one from hiding the other)."""

    def default(value: object) -> object:
        return argparse.SUPPRESS if after_command else value

    parser.add_argument(
        "--floorplan", type=Path, default=default(None), metavar="FILE",
        help=f"the building to plan and show routes on (default: the example care home, "
        f"{example}); the robot starts in its start room; floorplans/README.md has the "
        "format",
    )  # fmt: skip
    parser.add_argument(
        "--port", metavar="PORT|URL", default=default(None),
        help="the motor board's serial device or pyserial URL (default: from the settings "
        "file; without one, the built-in simulator)",
    )  # fmt: skip
    parser.add_argument(
        "--sim", action="store_true", default=default(False),
        help="use the built-in simulator, in the floor plan's building",
    )  # fmt: skip
    parser.add_argument(
        "--sim-speed", type=float, default=default(1.0), metavar="K",
        help="run the simulator's clock K times faster than real time; inf for as fast as "
        "it can (default: 1)",
    )  # fmt: skip
    parser.add_argument(
        "--sim-building", type=Path, default=default(None), metavar="FILE",
        help="put the simulated robot in FILE's building (its walls, furniture, doors, "
        "markers, and its dock to start on) instead of the console's floor plan's: a "
        "building the console is to map, or the one a plan was mapped from. The console "
        "still plans on its own floor plan, whose start room is where it takes the robot "
        "to stand",
    )  # fmt: skip
    parser.add_argument(
        "--lidar", metavar="PORT", nargs="?", const=SIMULATED_LIDAR, default=default(None),
        help="a Slamtec RPLIDAR's serial device or pyserial URL, for the obstacles in the "
        "way (default: the settings file's [lidar] port); with --sim and no PORT, the "
        "simulated lidar, which sees the building's walls and what is put in the way",
    )  # fmt: skip
    parser.add_argument(
        "--camera", metavar="DEVICE", default=default(None),
        help="camera index, device path or video file; or unix:PATH, a camera served on a "
        "Unix socket, as `sim --camera PATH` serves one (give --calibration "
        "PATH.calibration.yaml, which it writes). Default: the synthetic camera with the "
        "simulator, else camera 0; a test pattern if it is missing. Markers are found in "
        "its frames only with a calibration",
    )  # fmt: skip
    parser.add_argument(
        "--calibration", metavar="FILE", default=default(None),
        help="OpenCV fisheye calibration (camera_matrix, distortion_coefficients, "
        "image_width, image_height) to undistort the camera image and place markers",
    )  # fmt: skip
    parser.add_argument(
        "--at", metavar="ROOM[:DEG]", default=default(None),
        help="the robot stands at ROOM's point (dock: on its dock), facing the room's "
        "heading or DEG degrees: you say so, and missions set off from there (with "
        "markers in the plan they still look for one first, to confirm it). Without it, a "
        "real robot's pose is only assumed (the one it was last believed at, or the dock) "
        "until a marker confirms it, and no mission drives from an assumed pose. Never "
        "put it in a service unit that restarts the daemon",
    )  # fmt: skip
    add_firmware_option(parser, after_command=after_command)


def add_folder_options(parser: argparse.ArgumentParser, *, after_command: bool,
                       recordings: bool = True) -> None:  # fmt: skip
    """Where routes, patrols and (with `recordings`) sessions are kept."""
    default = argparse.SUPPRESS if after_command else None
    if recordings:
        parser.add_argument(
            "--recordings", type=Path, default=default, metavar="DIR",
            help="where sessions are recorded and looked for (default: the settings "
            f"file's `recordings`, else {default_recordings()})",
        )  # fmt: skip
    parser.add_argument(
        "--routes", type=Path, default=default, metavar="DIR",
        help="where taught routes and patrols are kept (default: the settings file's "
        f"`routes`, else {default_routes()})",
    )  # fmt: skip


def add_robot_options(parser: argparse.ArgumentParser, example: Path, *,
                      json: bool = True) -> None:  # fmt: skip
    """The options of every command that drives without the screen; `json` for one that
    ends and says how it went (`go`, `patrol`)."""
    add_board_options(parser, example, after_command=True)
    if json:
        parser.add_argument("--json", action="store_true", help="print how it went as JSON")
    parser.add_argument(
        "--imperfect", action="store_true",
        help="simulate a real robot's errors: distances, caster drift, stalls, ESTOP",
    )  # fmt: skip
    parser.add_argument("--seed", type=int, default=1, metavar="N", help="seed for --imperfect")
    parser.add_argument(
        "--faults", choices=("on", "off"), default="on",
        help="with --imperfect, off keeps the distance errors and caster drift but makes "
        "no random stalls or ESTOPs, which end missions by design (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument(
        "--no-landmarks", action="store_true",
        help="dead reckoning only: ignore the floor plan's markers (the estimate is then "
        "the odometry's)",
    )  # fmt: skip
    parser.add_argument(
        "--block", action="append", default=[], metavar="X,Y",
        help="put a 0.5 m box in the simulated building at X,Y metres (repeatable)",
    )  # fmt: skip
    parser.add_argument(
        "--sim-start", metavar="ROOM",
        help="put the simulated robot at ROOM's point, facing its heading, instead of on "
        "the dock; the console is not told and still assumes the dock",
    )  # fmt: skip
    parser.add_argument(
        "--move-marker", action="append", default=[], metavar="ID:DX",
        help="slide the simulated building's marker ID DX metres along its wall (positive: "
        "to your right as you face it), leaving the floor plan as it is (repeatable)",
    )  # fmt: skip
    parser.add_argument(
        "--sim-markers", type=Path, metavar="FILE",
        help="hang FILE's markers (a floor plan's landmarks) in the simulated building "
        "instead of the plan's: a plan without them, or surveyed, against the true ones",
    )  # fmt: skip
    parser.add_argument(
        "--eye-fps", type=float, metavar="F",
        help=f"frames a second the simulated camera looks for markers (default: {EYE_FPS:g})",
    )  # fmt: skip
    parser.add_argument(
        "--eye-size", metavar="WxH",
        help=f"the simulated camera's frame size (default: {EYE_SIZE[0]}x{EYE_SIZE[1]})",
    )  # fmt: skip


def robot_options(args: argparse.Namespace, settings: Settings, *, screen: bool = False,
                  shares_camera: bool = False, surveying: Landmarks | None = None,
                  virtual_port: bool = False) -> RobotOptions:  # fmt: skip
    """The robot the command line asks for: the simulator with --sim, else --port, else
    the settings file's port (none: the simulator)."""
    from giraff_console.runtime.options import RobotOptions

    def given(name: str, default: Any = None) -> Any:
        return getattr(args, name, default)

    return RobotOptions(
        port=None if args.sim else (args.port or settings.port),
        floorplan=given("floorplan"),
        routes=given("routes"),
        recordings=given("recordings"),
        at=given("at"),
        camera=given("camera"),
        calibration=given("calibration"),
        fast_threshold=given("fast_threshold", FAST_THRESHOLD),
        camera_fps=given("camera_fps", DEFAULT_FPS),
        landmarks=not given("no_landmarks", False),
        screen=screen,
        shares_camera=shares_camera,
        surveying=surveying,
        virtual_port=virtual_port,
        firmware=given("firmware"),
        sim_speed=args.sim_speed,
        imperfect_seed=given("seed", 1) if given("imperfect", False) else None,
        faults=given("faults", "on") == "on",
        blocks=tuple(given("block", ())),
        sim_start=given("sim_start"),
        move_markers=tuple(given("move_marker", ())),
        sim_markers=given("sim_markers"),
        sim_building=given("sim_building"),
        eye_fps=given("eye_fps"),
        eye_size=given("eye_size"),
        lidar=given("lidar"),
    )
