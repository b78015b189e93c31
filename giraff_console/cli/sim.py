"""`giraff-console sim`: the simulated motor board on a pseudo-terminal, for any serial
program to open as it would a real board; with a floor plan, its camera too.
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. What a command needs to run
# (numpy, OpenCV, scipy, the planner, the robot, Textual) is imported by the command,
# when it runs (issue 26, item 6; tests/test_cli.py keeps it so).
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.cli.simulator_options import add_firmware_option
from giraff_console.protocol.kinematics import WHEEL_BASE_M, WHEEL_BASE_RANGE_M

if TYPE_CHECKING:
    from giraff_console.planning.floorplan import FloorPlan
    from giraff_console.sim import GiraffBoard
    from giraff_console.sim.camera_server import CameraServer
    from giraff_console.sim.lidar import SimLidar


def add_sim_parser(commands: argparse._SubParsersAction) -> None:
    sim = commands.add_parser(
        "sim",
        help="serve a simulated motor board on a pseudo-terminal",
        description="Serve a simulated Giraff motor board on a new pseudo-terminal. The "
        "device path is printed alone on the first line of standard output; any serial "
        "program can then open it like a real board. With --lidar, a simulated Slamtec "
        "RPLIDAR is served on a second pseudo-terminal, whose path is the second line. "
        "Runs until SIGINT or SIGTERM. The board keeps moving when a program closes the "
        "port, as a real board does.",
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
        "--lidar", action="store_true",
        help="also serve a simulated Slamtec RPLIDAR A1 (its serial protocol, normal scans) "
        "on a second pseudo-terminal, printed on the second line of standard output; it "
        "sees the floor plan's walls and shut doors from the robot's true pose; with "
        "--imperfect, the datasheet's range noise, seeded by --seed",
    )  # fmt: skip
    sim.add_argument(
        "--lidar-rate", type=float, default=5.5, metavar="HZ",
        help="the lidar's revolutions a second, 1 to 20 (default: %(default)s, an A1's; "
        "an A2 turns up to 10)",
    )  # fmt: skip
    sim.add_argument(
        "--lidar-samples", type=int, default=360, metavar="N",
        help="the lidar's samples a revolution, 16 to 4000 (default: %(default)s)",
    )  # fmt: skip
    sim.add_argument(
        "--lidar-health", choices=("good", "warning", "error"), default="good",
        help="what the lidar says of its health; error: a protection stop, in which it "
        "does not scan (default: %(default)s)",
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
    lidar = None
    if args.lidar:
        try:
            lidar = simulated_lidar(board, plan, args)
        except ValueError as error:
            print(f"giraff-console: --lidar: {error}", file=sys.stderr)
            return EXIT_USAGE
    try:
        return serve_board(board, args, camera, lidar)
    finally:
        if camera is not None:
            camera.close()


def simulated_lidar(board: GiraffBoard, plan: FloorPlan | None,
                    args: argparse.Namespace) -> SimLidar:  # fmt: skip
    """The simulated RPLIDAR on the board's robot, seeing the plan's walls and shut doors
    (none without a plan); ValueError for a rate or sample count it cannot have."""
    from giraff_console.planning.route_planner import walls_of
    from giraff_console.protocol.rplidar import Health
    from giraff_console.runtime.sim_site import building_walls, shut_doors
    from giraff_console.sim.lidar import LidarConfig, LidarWorld, SimLidar

    health = {"good": Health.GOOD, "warning": Health.WARNING, "error": Health.ERROR}
    config = LidarConfig(args.lidar_rate, args.lidar_samples, noise=args.imperfect,
                         seed=args.seed, health=health[args.lidar_health])  # fmt: skip
    walls, surroundings = [], None
    if plan is not None:
        grid = walls_of(plan) if plan.grid is not None else None
        walls = [(wall.a, wall.b) for wall in building_walls(plan, grid)]
        surroundings = shut_doors(plan, grid)
    return SimLidar(LidarWorld(lambda: board.true_pose, walls, surroundings), config)


def serve_board(board: GiraffBoard, args: argparse.Namespace, camera: CameraServer | None,
                lidar: SimLidar | None = None) -> int:  # fmt: skip
    """The board on a new pty, and `camera` and `lidar` beside it, until SIGINT or
    SIGTERM."""
    from giraff_console.sim import PtyServer
    from giraff_console.sim.lidar_pty import LidarPtyServer
    from giraff_console.sim.pose_log import PoseLog

    server = PtyServer(board, paced=args.pace)
    lidar_server = LidarPtyServer(lidar) if lidar is not None else None
    signal.signal(signal.SIGTERM, lambda *_: server.stop())
    signal.signal(signal.SIGINT, lambda *_: server.stop())
    try:
        pose_log = PoseLog(board, args.pose_log) if args.pose_log else None
    except OSError as error:
        print(f"giraff-console: cannot write the pose log: {error}", file=sys.stderr)
        server.close()
        if lidar_server is not None:
            lidar_server.close()
        return EXIT_USAGE
    if camera is not None:
        camera.start()  # before the pty's path is printed: then both are ready
    if lidar_server is not None:
        lidar_server.start()
    print(server.path, flush=True)
    if lidar_server is not None:
        print(lidar_server.path, flush=True)
        print(f"giraff-console sim: lidar on {lidar_server.path}", file=sys.stderr)
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
        if lidar_server is not None:
            lidar_server.close()
        if pose_log is not None:
            pose_log.close()
    return 0
