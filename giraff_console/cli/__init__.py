"""The `giraff-console` command line: the parser, and which command runs; each command
lives in its own module beside this one."""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import shutil
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. What a command needs to run
# (numpy, OpenCV, scipy, the planner, the robot, Textual) is imported by the command,
# when it runs (issue 26, item 6; tests/test_cli.py keeps it so).
from giraff_console import __version__
from giraff_console.camera.defaults import DEFAULT_FPS, FAST_THRESHOLD
from giraff_console.cli.daemon import (
    add_daemon_parsers,
    run_patrols,
    run_status,
    run_stop,
    run_watch,
)
from giraff_console.cli.go import add_go_parser, run_go
from giraff_console.cli.options import add_board_options, add_folder_options
from giraff_console.cli.patrol import add_patrol_parser, run_patrol
from giraff_console.cli.send import add_send_parser, run_send
from giraff_console.cli.serve import add_serve_parser, run_serve
from giraff_console.cli.simulator_options import add_firmware_option
from giraff_console.cli.survey import add_survey_parser, run_survey
from giraff_console.data_folders import config_path, example_floorplan
from giraff_console.planning.defaults import DEFAULT_EVERY_M, MIN_ROOM_M2, ROBOT_RADIUS_M
from giraff_console.protocol.kinematics import WHEEL_BASE_M, WHEEL_BASE_RANGE_M
from giraff_console.robot.last_stop import SIGNALS

if TYPE_CHECKING:
    from giraff_console.settings import Settings
    from giraff_console.sim import GiraffBoard
    from giraff_console.sim.camera_server import CameraServer

# Exit code: a mistake in the command line or the settings.
EXIT_USAGE = 2

# No route between two rooms that exist.
EXIT_NO_ROUTE = 1
# Shipped in the package, so that the console, `plan` and `go` work from any folder.
EXAMPLE_FLOORPLAN = example_floorplan()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="giraff-console",
        # Abbreviations would make `sim --ca` ambiguous with --camera and --calibration.
        allow_abbrev=False,
        description="Operator console for the Giraff telepresence robot, with a faithful "
        "simulator of its motor board. Without a COMMAND it opens the console: hold the "
        "arrow keys to drive, Enter for the command line, ? for help, Esc to stop and quit.",
    )
    parser.add_argument("--version", action="version", version=f"giraff-console {__version__}")
    add_board_options(parser, EXAMPLE_FLOORPLAN, after_command=False)
    parser.add_argument(
        "--fast-threshold", type=int, default=FAST_THRESHOLD, metavar="N",
        help="FAST corner threshold (default: %(default)s, as in the thesis)",
    )  # fmt: skip
    parser.add_argument(
        "--camera-fps", type=float, default=DEFAULT_FPS, metavar="FPS",
        help="cap on camera frames per second (default: %(default)s)",
    )  # fmt: skip
    add_folder_options(parser, after_command=False)
    parser.add_argument(
        "--config", metavar="FILE", type=Path,
        help=f"settings file (default: {config_path()}); see the README for its keys",
    )  # fmt: skip
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")

    sim = commands.add_parser(
        "sim",
        help="serve a simulated motor board on a pseudo-terminal",
        description="Serve a simulated Giraff motor board on a new pseudo-terminal. The "
        "device path is printed alone on the first line of standard output; any serial "
        "program can then open it like a real board. Runs until SIGINT or SIGTERM. The "
        "board keeps moving when a program closes the port, as a real board does.",
    )
    sim.add_argument(
        "--pty",
        action="store_true",
        help="serve on a pseudo-terminal (the only transport; accepted for clarity)",
    )
    sim.add_argument(
        "--pace", action="store_true", help="delay every byte as a 115200-baud line would"
    )
    sim.add_argument(
        "--imperfect",
        action="store_true",
        help="model a real robot: distance errors, caster drift, stalls, ESTOP",
    )
    sim.add_argument("--seed", type=int, metavar="N", help="seed for --imperfect (default: random)")
    sim.add_argument("--ca", action="store_true", help="print a Ca> line before the banner")
    sim.add_argument("--hex-upper", action="store_true", help="upper-case hex in replies")
    sim.add_argument(
        "--set-reply",
        choices=("value", "none", "labelled"),
        default="value",
        help="how a set is answered (default: value, as in the thesis)",
    )
    sim.add_argument("--auto-home", action="store_true", help="home the head at power-up")
    add_firmware_option(sim, after_command=True)
    sim.add_argument(
        "--battery", type=float, default=1.0, metavar="LEVEL",
        help="the battery's charge at power-on, 0 to 1, shown by charger_data on later "
        "firmware (default: %(default)s)",
    )  # fmt: skip
    sim.add_argument(
        "--wheel-base", type=float, default=WHEEL_BASE_M, metavar="M",
        help="the robot's real distance between the wheels, which the firmware does not "
        "know: it drives by 0.499 m (default: %(default)s; one driver uses 0.467)",
    )  # fmt: skip
    sim.add_argument(
        "--floorplan", type=Path, default=argparse.SUPPRESS, metavar="FILE",
        help="put the robot at this floor plan's start room, facing its heading, on its "
        "dock (default: at the origin, facing +x, with no dock)",
    )  # fmt: skip
    sim.add_argument(
        "--modem-shim", action="store_true",
        help="print the path of a library that gives the pty modem lines (DTR, RTS) for C "
        "and C++ drivers, to LD_PRELOAD (built with the C compiler on first use), and exit",
    )  # fmt: skip
    sim.add_argument(
        "--pose-log",
        type=Path,
        metavar="FILE",
        help="write the true pose (never on the wire) to FILE every 20 ms",
    )
    sim.add_argument(
        "--camera", type=Path, dest="camera_socket", metavar="SOCKET",
        help="with --floorplan: also serve what a camera on the robot sees (the plan's "
        "walls, doors and markers, drawn from the robot's true pose) on a Unix socket at "
        "SOCKET, only this user's, in a folder not every user may write to, and write its "
        "calibration to SOCKET.calibration.yaml; the console reads it with --camera "
        "unix:SOCKET --calibration SOCKET.calibration.yaml. Both are removed on exit",
    )  # fmt: skip

    replay = commands.add_parser(
        "replay",
        help="open the console and play a recorded session back",
        description="Open the console and play SESSION back: the transcript, the pose and "
        "the video as they were recorded, at the recorded speed. Nothing is sent to the "
        "robot. k pauses, . steps, j and l seek, < and > change the speed, p returns to "
        "live. SESSION is a recordings/ directory, or a log written by the original console.",
    )
    replay.add_argument("session", type=Path, metavar="SESSION")

    export = commands.add_parser(
        "export",
        help="export a recorded session to MCAP, for Foxglove",
        description="Write SESSION's controller transcript, odometry pose, the pose "
        "filter's estimate with its covariance (sessions recorded with the filter) and JPEG "
        "camera frames to OUT as MCAP channels (/controller, /pose, /pose_estimate, /camera) "
        "with JSON schemas. /pose is the odometry's (frame odom); /pose_estimate is "
        "giraff.PoseWithCovarianceInFrame (frame map): a foxglove.PoseInFrame with a "
        "row-major 6x6 covariance over x, y, z, roll, pitch, yaw, in which z, roll and pitch "
        "are 0. See recordings/README.md.",
    )
    export.add_argument("session", type=Path, metavar="SESSION")
    export.add_argument("out", type=Path, metavar="OUT.mcap")

    plan = commands.add_parser(
        "plan",
        help="plan a route between two rooms of a floor plan",
        description="Plan the shortest route from room FROM to room TO: the doors to pass "
        "from A* over the floor plan's room graph (§2.6.2), the way across each room from "
        "D* Lite on its grid (§2.6.4), for a robot of 0.3 m radius. Prints the rooms and "
        "doors passed, the length and the polyline. Exits 2 for an unknown room or a bad "
        "floor plan, 1 when there is no route.",
    )
    plan.add_argument(
        # SUPPRESS: given here or before the command (`giraff-console --floorplan F plan`).
        "--floorplan", type=Path, default=argparse.SUPPRESS, metavar="FILE",
        help=f"floor plan YAML (default: the example care home, {EXAMPLE_FLOORPLAN}); "
        "floorplans/README.md has the format",
    )  # fmt: skip
    plan.add_argument("--json", action="store_true", help="print the route as JSON")
    plan.add_argument(
        "--robot-radius", type=float, default=ROBOT_RADIUS_M, metavar="M",
        help="metres the walls are grown by for planning (default: %(default)s)",
    )  # fmt: skip
    plan.add_argument("origin", metavar="FROM", help="room id to start from, e.g. dock")
    plan.add_argument("destination", metavar="TO", help="room id to go to, e.g. day-room")

    floorplan = commands.add_parser(
        "floorplan",
        help="check a floor plan file",
        description="Check FILE against the floor plan format (floorplans/README.md) and "
        "print every problem as FILE:LINE: message. Exits 0 if there is none, 2 otherwise.",
    )
    floorplan_commands = floorplan.add_subparsers(dest="floorplan_command", metavar="ACTION",
                                                  required=True)  # fmt: skip
    check = floorplan_commands.add_parser("check", help="report every problem in a floor plan")
    check.add_argument("file", type=Path, metavar="FILE")
    show = floorplan_commands.add_parser(
        "show", help="draw a floor plan in the terminal",
        description="Draw FILE's grid (or, without one, its outlines) with each room's id.",
    )  # fmt: skip
    show.add_argument("file", type=Path, metavar="FILE")
    show.add_argument(
        "--width", type=int, metavar="COLUMNS",
        help="columns to fit the drawing in (default: the terminal's width)",
    )  # fmt: skip
    imports = floorplan_commands.add_parser(
        "import", help="make a floor plan from an Open-RMF building map",
        description="Write OUT, a floor plan made from one level of SOURCE, an Open-RMF "
        "*.building.yaml as traffic-editor saves it: its named vertices become rooms, the "
        "spaces its walls and doors bound (or, without walls, its lanes) say which rooms "
        "its doors join, and passages join rooms that share a space. With walls, the grid "
        "is drawn from them and written next to OUT as a PGM (floorplans/README.md, "
        "\"Importing\"). What the import decides for the map is told in notes, at their "
        "lines. The result must pass `floorplan check`, or nothing is written. Exits 0 "
        "when written, 2 for a bad SOURCE or MAP.",
    )  # fmt: skip
    imports.add_argument("source", type=Path, metavar="SOURCE.building.yaml")
    imports.add_argument("out", type=Path, metavar="OUT.yaml")
    imports.add_argument(
        "--level", metavar="NAME",
        help="the level to import (default: the only one; a map of several must say which)",
    )  # fmt: skip
    imports.add_argument(
        "--graph", type=int, metavar="N",
        help="only the lanes of graph N (a fleet's graph_idx), and the named vertices on "
        "them or on no lane (default: every graph's)",
    )  # fmt: skip
    imports.add_argument(
        "--grid", type=Path, metavar="MAP.yaml",
        help="a ROS map_server map to use as the grid, instead of the one drawn from the "
        "walls; its image is copied next to OUT",
    )  # fmt: skip
    imports.add_argument(
        "--name", metavar="TEXT", help="the floor plan's name (default: building and level)",
    )  # fmt: skip
    imports.add_argument("--force", action="store_true", help="overwrite OUT and its image")
    landmarks = floorplan_commands.add_parser(
        "landmarks", help="place markers on a floor plan's walls, or print them",
        description="Place fiducial markers (AprilTag 36h11) on FILE's walls, for the robot "
        "to find itself by: beside every doorway on both sides, along walls at least M "
        "metres long, and on the wall nearest any room's stop that would read too few to "
        "confirm an arrival there; and write them into FILE (floorplans/README.md, "
        "\"Landmarks\"). The walls are the rooms' outlines, or in a plan without outlines "
        "(an import, rooms found in a scan) the walls in its grid, where the robot sees "
        "them. Markers already there stay, at the plan's size. A plan without markers gets "
        "them 0.16 m across, or larger where a room's stop is far from every wall (up to "
        "0.26 m), unless --size says. With --print, write one page per marker to DIR "
        "instead, to print at actual size and put up. Exits 2 for a bad floor plan.",
    )  # fmt: skip
    landmarks.add_argument("file", type=Path, metavar="FILE")
    landmarks_action = landmarks.add_mutually_exclusive_group()
    landmarks_action.add_argument(
        "--every", type=float, default=DEFAULT_EVERY_M, metavar="M",
        help="metres between markers along a long wall (default: %(default)s)",
    )  # fmt: skip
    landmarks.add_argument(
        "--size", type=float, metavar="M",
        help="the side of the markers' black squares in metres, for a plan without markers "
        "(default: the least that every room's stop reads, 0.16 to 0.26)",
    )  # fmt: skip
    landmarks_action.add_argument(
        "--print", type=Path, metavar="DIR", dest="print_to",
        help="write a PNG page for each marker in FILE, and all of them in DIR/markers.pdf",
    )  # fmt: skip
    rooms = floorplan_commands.add_parser(
        "rooms", help="find the rooms and doors in a scanned map",
        description="Write OUT, a floor plan of the rooms and doors found in MAP, a ROS "
        "map_server map such as SLAM leaves (floorplans/README.md, \"Rooms from a scan\"). "
        "Rooms are where the free space is wide, doors where it narrows between them; "
        "rooms are named room-1, room-2, ... from the top left, each with its point where "
        "it is furthest from walls, and the plan has no outlines: the grid is its walls, "
        "and its grid is written next to OUT: the map's image copied, or, when the map "
        "had to be cropped to its floor or cleared of specks of noise, the grid so "
        "redrawn (MAP itself is never changed). Rooms the route planner cannot reach "
        "from the rest are left out, with a note. A picture of what was found (each room "
        "tinted and named, doors in red) goes next to OUT too. The plan must pass "
        "`floorplan check`, or nothing is written. Exits 0 when written, 2 for a map that "
        "cannot be read or has no rooms in it, for several rooms no two of which the "
        "robot can be planned between, and for an output that cannot be written.",
    )  # fmt: skip
    rooms.add_argument("map", type=Path, metavar="MAP.yaml")
    rooms.add_argument("out", type=Path, metavar="OUT.yaml")
    rooms.add_argument(
        "--picture", type=Path, metavar="PNG",
        help="where to draw the rooms found (default: beside OUT, plan.yaml's is "
        "plan-rooms.png)",
    )  # fmt: skip
    rooms.add_argument(
        "--name", metavar="TEXT", help="the floor plan's name (default: from MAP's name)",
    )  # fmt: skip
    rooms.add_argument(
        "--robot-radius", type=float, default=ROBOT_RADIUS_M, metavar="M",
        help="free space narrower than twice this and the route planner's 0.05 m "
        "clearance is no room, and no door (default: %(default)s)",
    )  # fmt: skip
    rooms.add_argument(
        "--min-area", type=float, default=MIN_ROOM_M2, metavar="M2",
        help="square metres of floor a room needs; smaller pieces join their "
        "neighbours (default: %(default)s)",
    )  # fmt: skip
    rooms.add_argument("--force", action="store_true",
                       help="overwrite OUT, its image and the picture")  # fmt: skip

    add_go_parser(commands, EXAMPLE_FLOORPLAN)
    add_patrol_parser(commands, EXAMPLE_FLOORPLAN)
    add_serve_parser(commands, EXAMPLE_FLOORPLAN)
    add_survey_parser(commands, EXAMPLE_FLOORPLAN)
    add_daemon_parsers(commands)

    add_send_parser(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        return run(build_parser().parse_args(argv))
    except BrokenPipeError:
        # The output went to a pager or `head` that stopped reading: not an error.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


# The commands that drive the robot (the console too, with no command or `replay`).
DRIVING: dict[str | None, Callable[[argparse.Namespace, Settings, Path], int]] = {
    "go": run_go, "patrol": run_patrol, "serve": run_serve, "survey": run_survey,
}  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """The command `args` names."""
    if args.command not in (None, "replay", "go", "patrol", "serve", "survey"):
        # Nothing here drives by itself: signals end the command as usual. The program's
        # entry point blocked them for the console's own watcher (launch.py).
        signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)
    if args.command == "sim":
        return run_sim(args)
    if args.command == "send":
        return run_send(args)
    if args.command == "export":
        return run_export(args)
    if args.command == "plan":
        return run_plan(args)
    if args.command == "status":
        return run_status(args)
    if args.command == "stop":
        return run_stop(args)
    if args.command == "patrols":
        return run_patrols(args)
    if args.command == "watch":
        return run_watch(args)
    if args.command == "floorplan" and args.floorplan_command == "show":
        return run_floorplan_show(args)
    if args.command == "floorplan" and args.floorplan_command == "import":
        return run_floorplan_import(args)
    if args.command == "floorplan" and args.floorplan_command == "landmarks":
        return run_floorplan_landmarks(args)
    if args.command == "floorplan" and args.floorplan_command == "rooms":
        return run_floorplan_rooms(args)
    if args.command == "floorplan":
        return run_floorplan_check(args)
    # The commands that drive the robot, on the settings file's rates and limits: the
    # console with no command (or replay), the only one that loads Textual.
    command = DRIVING[args.command] if args.command in DRIVING else load_console()
    from giraff_console.settings import SettingsError, load_settings

    try:
        settings = load_settings(args.config)
    except SettingsError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    return command(args, settings, EXAMPLE_FLOORPLAN)


def load_console() -> Callable[[argparse.Namespace, Settings, Path], int]:
    """The console, loaded: most of the package, numpy, OpenCV and Textual.

    All of it lives as long as the console runs. Python's collector walked it again and
    again as it loaded, as the robot was built and as the first screen was drawn: 0.08 s
    of that screen's 0.66 s of CPU (issue 26, item 6). So the collector waits until it
    is loaded, then leaves it out of its rounds for good (gc.freeze); what the console
    makes from then on is collected as before. Only the console: a program that calls
    main() again and again (the tests) would keep whatever it had left to collect."""
    gc.disable()
    try:
        from giraff_console.cli.console import run_console
    finally:
        gc.freeze()
        gc.enable()
    return run_console


def run_plan(args: argparse.Namespace) -> int:
    """The route between two rooms, as text or JSON."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.room_graph import PlanningError, UnknownRoomError
    from giraff_console.planning.route_planner import RoutePlanner, walls_of

    try:
        plan = load_floorplan(args.floorplan or EXAMPLE_FLOORPLAN)
        planner = RoutePlanner(plan, walls_of(plan), args.robot_radius)
        planned = planner.between_rooms(args.origin, args.destination)
    except (FloorPlanError, OSError, UnknownRoomError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except PlanningError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_NO_ROUTE
    if args.json:
        print(json.dumps(planned.as_json()))
    else:
        print(f"{' → '.join(planned.route.rooms)}: {planned.length_m:.2f} m")
        print(f"doors: {', '.join(planned.route.doors) or 'none'}")
    return 0


def run_floorplan_check(args: argparse.Namespace) -> int:
    """Every problem in a floor plan, one per line."""
    from giraff_console.planning.floorplan import check_floorplan

    problems = check_floorplan(args.file)
    for problem in problems:
        print(problem)
    if problems:
        return EXIT_USAGE
    print(f"{args.file}: no problems")
    return 0


def run_floorplan_show(args: argparse.Namespace) -> int:
    """The plan drawn in the terminal."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.plan_drawing import draw_plan

    width = args.width or shutil.get_terminal_size().columns
    try:
        lines = draw_plan(load_floorplan(args.file), width)
    except (FloorPlanError, OSError, ValueError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    print("\n".join(lines))
    return 0


def run_floorplan_import(args: argparse.Namespace) -> int:
    """A floor plan made from an Open-RMF building map, with a grid drawn from its walls or
    a ROS map's."""
    # Imported here: of all the commands, only this one reads RMF and ROS maps.
    from giraff_console.planning.floorplan import FloorPlanError
    from giraff_console.planning.output_files import OutputError, check_outputs
    from giraff_console.planning.plan_writing import write_floorplan
    from giraff_console.planning.rmf_import import read_building
    from giraff_console.planning.rmf_source import BuildingError
    from giraff_console.planning.ros_map import read_ros_map

    imported = None

    def tell_notes(notes: list[str]) -> None:
        # Each is `file:line: note: ...`, in the order of the lines.
        for note in notes:
            print(f"giraff-console: {note}", file=sys.stderr)

    try:
        imported = read_building(args.source, args.level, args.name, args.graph)
        grid = read_ros_map(args.grid) if args.grid is not None else None
        # Never over SOURCE or MAP, --force or not: it is for an old result.
        inputs = [("SOURCE", args.source)]
        outputs = [("OUT", args.out)]
        if grid is not None:
            inputs += [("MAP", args.grid), ("MAP's image", grid.image)]
            image = args.out.with_suffix(grid.image.suffix)
            if not (image.exists() and image.samefile(grid.image)):  # else used as it is
                outputs.append(("OUT's grid image", image))
        elif imported.drawn is not None:
            outputs.append(("OUT's grid image", args.out.with_suffix(".pgm")))
        check_outputs(outputs, inputs, args.force)
        written = write_floorplan(imported, args.out, grid, force=args.force)
    except OutputError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FloorPlanError as error:
        tell_notes(error.notes if isinstance(error, BuildingError) else
                   imported.notes if imported is not None else [])  # fmt: skip
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FileExistsError as error:
        print(f"giraff-console: {error.filename} exists: --force overwrites it", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"giraff-console: cannot write {args.out}: {error}", file=sys.stderr)
        return EXIT_USAGE
    tell_notes(imported.notes)
    plan = imported.plan
    rooms, doors = plan["rooms"], [door["id"] for door in plan["doors"]]
    start = f", starting in {plan['start']}" if "start" in plan else ""
    print(f"wrote {written[0]}: {len(rooms)} rooms ({', '.join(rooms)}), "
          f"{len(doors)} doors ({', '.join(doors) or 'none'}){start}")  # fmt: skip
    for image in written[1:]:
        made = f"the grid image of {args.grid}" if args.grid is not None else (
            "the grid, drawn from the level's walls and doors")  # fmt: skip
        print(f"wrote {image}: {made}")
    return 0


def run_floorplan_landmarks(args: argparse.Namespace) -> int:
    """Markers placed on a floor plan and written into it, or its markers' pages."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.landmark_placement import place_markers, write_landmarks
    from giraff_console.planning.marker_pages import write_pages

    try:
        plan = load_floorplan(args.file)
        if args.print_to is not None:
            written = write_pages(plan, args.print_to)
            pages = f"{len(written) - 1} page{'s' if len(written) != 2 else ''}"
            print(f"wrote {pages} to {args.print_to}, and all of them in "
                  f"{written[-1]}: print them at actual size (100 %)")  # fmt: skip
            return 0
        placement = place_markers(plan, args.every, args.size)
        if placement.added:
            write_landmarks(plan, placement.landmarks)
    except (FloorPlanError, ValueError, OSError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    for note in placement.notes:
        print(f"giraff-console: {args.file}: {note}", file=sys.stderr)
    total = len(placement.landmarks.markers)
    print(f"{args.file}: placed {placement.added} markers ({placement.beside_doors} beside "
          f"doorways, {placement.along_walls} along walls, {placement.for_stops} for rooms' "
          f"stops); it has {total} in all, {placement.landmarks.size:g} m across")  # fmt: skip
    return 0


def run_floorplan_rooms(args: argparse.Namespace) -> int:
    """A floor plan of the rooms found in a scanned map, and a picture of them."""
    # Imported here: of all the commands, only this one segments maps.
    from giraff_console.planning.floorplan import FloorPlanError
    from giraff_console.planning.output_files import OutputError, check_outputs
    from giraff_console.planning.plan_writing import write_floorplan
    from giraff_console.planning.room_picture import draw_rooms, encode_png
    from giraff_console.planning.room_segmentation import (
        SegmentationError,
        scan_plan,
        segment_rooms,
    )
    from giraff_console.planning.scan_grid import read_scan

    for option, value in (("--robot-radius", args.robot_radius), ("--min-area", args.min_area)):
        if not (value > 0 and math.isfinite(value)):
            print(f"giraff-console: {option} must be a positive number", file=sys.stderr)
            return EXIT_USAGE
    picture = args.picture or args.out.with_name(f"{args.out.stem}-rooms.png")
    try:
        scan = read_scan(args.map)
        found = segment_rooms(scan.grid, args.robot_radius, args.min_area, scan.cropped)
    except FloorPlanError as error:
        for problem in error.problems:
            print(f"giraff-console: {problem}", file=sys.stderr)
        return EXIT_USAGE
    except SegmentationError as error:
        print(f"giraff-console: {args.map}: {error}", file=sys.stderr)
        return EXIT_USAGE
    # A grid cropped or cleaned is written as a PGM; the map's own is copied as it is.
    image = args.out.with_suffix(".pgm" if found.redrawn else scan.spec.image.suffix)
    try:
        outputs = [("OUT", args.out), ("OUT's grid image", image), ("--picture", picture)]
        check_outputs(outputs, [("MAP", args.map), ("MAP's image", scan.spec.image)], args.force)
        # Drawn before anything is written, so that a failure leaves nothing behind.
        png = encode_png(draw_rooms(found))
        name = args.name or f"Rooms found in {args.map.name}"
        made = scan_plan(found, args.map, name)
        written = write_floorplan(made, args.out, None if found.redrawn else scan.spec,
                                  args.force)  # fmt: skip
        picture.write_bytes(png)
    except OutputError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except FloorPlanError as error:
        for problem in error.problems:
            print(f"giraff-console: {problem}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"giraff-console: cannot write {error.filename or args.out}: "
              f"{error.strerror or error}", file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    for note in (*scan.notes, *found.notes):
        print(f"giraff-console: {args.map}: {note}", file=sys.stderr)
    rooms = [room.id for room in found.rooms]
    named = f"{rooms[0]} to {rooms[-1]}" if len(rooms) > 1 else rooms[0]
    doors = ", ".join(door.id for door in found.doors) or "none"
    rooms_s, doors_s = "s" * (len(rooms) != 1), "s" * (len(found.doors) != 1)
    print(f"wrote {written[0]}: {len(rooms)} room{rooms_s} ({named}), {len(found.doors)} "
          f"door{doors_s} ({doors}), starting in {found.start}")  # fmt: skip
    made_as = "redrawn as noted above" if found.redrawn else "its image copied"
    for grid_image in written[1:]:
        print(f"wrote {grid_image}: the grid of {args.map}, {made_as}")
    print(f"wrote {picture}: the rooms found, to check and name")
    return 0


def run_export(args: argparse.Namespace) -> int:
    """A recorded session as an MCAP file."""
    from giraff_console.recording.mcap_export import export_session
    from giraff_console.recording.playback import open_log
    from giraff_console.recording.session import SessionError, SessionStart, read_meta
    from giraff_console.robot.replay import replay_poses

    try:
        _, log = open_log(args.session)
        meta = read_meta(args.session) if args.session.is_dir() else {}
        poses = replay_poses(log, SessionStart.from_meta(meta))
        summary = export_session(args.session, args.out, poses)
    except SessionError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    for problem in summary.problems:
        print(f"giraff-console: {problem}", file=sys.stderr)
    counts = ", ".join(f"{topic} {count}" for topic, count in summary.channels.items())
    print(f"{args.out}: {counts}")
    return 0


def run_sim(args: argparse.Namespace) -> int:
    from giraff_console.sim.modem_shim import main as print_modem_shim

    if args.modem_shim:
        return print_modem_shim()
    from giraff_console.clock import RealClock
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.runtime.camera import plan_camera
    from giraff_console.sim import BoardConfig, GiraffBoard, Imperfections
    from giraff_console.sim.camera_server import CameraServer, CameraServerError
    from giraff_console.sim.drive import TruePose
    from giraff_console.sim.firmware import DEFAULT_FIRMWARE, FIRMWARES

    imperfections = Imperfections.realistic(args.seed) if args.imperfect else Imperfections()
    low, high = WHEEL_BASE_RANGE_M
    if not 0 <= args.battery <= 1 or not low <= args.wheel_base <= high:
        print(f"giraff-console: --battery must be from 0 to 1 and --wheel-base from {low:g} to "
              f"{high:g} m",
              file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    config = BoardConfig(
        calibration_line=args.ca,
        hex_upper=args.hex_upper,
        set_reply=args.set_reply,
        auto_home=args.auto_home,
        imperfections=imperfections,
        firmware=FIRMWARES[args.firmware or DEFAULT_FIRMWARE],
        battery=args.battery,
        wheel_base=args.wheel_base,
    )
    board = GiraffBoard(RealClock(), config)
    plan = None
    if args.floorplan is not None:
        try:
            plan = load_floorplan(args.floorplan)
        except FloorPlanError as error:
            print(f"giraff-console: {error}", file=sys.stderr)
            return EXIT_USAGE
        if plan.start is not None:
            room = plan.rooms[plan.start]
            # The start room is where the robot docks (its point and heading).
            board.dock = TruePose(room.at[0], room.at[1], math.radians(room.heading or 0.0))
            board.place(board.dock)
    camera = None
    if args.camera_socket is not None:
        if plan is None:
            print("giraff-console: --camera needs --floorplan: the camera sees the plan's "
                  "building", file=sys.stderr)  # fmt: skip
            return EXIT_USAGE
        try:
            # Before any thread starts: it sets the process's umask for a moment.
            camera = CameraServer(args.camera_socket, plan_camera(plan),
                                  lambda: board.true_pose)  # fmt: skip
        except (CameraServerError, OSError) as error:
            print(f"giraff-console: {error}", file=sys.stderr)
            return EXIT_USAGE
    try:
        return serve_board(board, args, camera)
    finally:
        if camera is not None:
            camera.close()


def serve_board(board: GiraffBoard, args: argparse.Namespace, camera: CameraServer | None) -> int:
    """The board on a new pty, and `camera` beside it, until SIGINT or SIGTERM."""
    from giraff_console.sim import PtyServer
    from giraff_console.sim.pose_log import PoseLog

    server = PtyServer(board, paced=args.pace)
    signal.signal(signal.SIGTERM, lambda *_: server.stop())
    signal.signal(signal.SIGINT, lambda *_: server.stop())
    try:
        pose_log = PoseLog(board, args.pose_log) if args.pose_log else None
    except OSError as error:
        print(f"giraff-console: cannot write the pose log: {error}", file=sys.stderr)
        server.close()
        return EXIT_USAGE
    if camera is not None:
        camera.start()  # before the pty's path is printed: then both are ready
    print(server.path, flush=True)
    print(f"giraff-console sim: board on {server.path}; Ctrl-C to stop", file=sys.stderr)
    if camera is not None:
        print(f"giraff-console sim: camera on {camera.path}, calibration "
              f"{camera.calibration_path}; the console takes them with --camera "
              f"unix:{camera.path} --calibration {camera.calibration_path}",
              file=sys.stderr)  # fmt: skip
    try:
        server.serve_forever()
    finally:
        server.close()
        if pose_log is not None:
            pose_log.close()
    return 0
