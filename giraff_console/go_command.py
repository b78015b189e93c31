"""`giraff-console go ROOM`: take the robot to a room without the console's screen.

`go dock` drives onto the dock, square on (missions/docking.py).

The same mission the console's `go` runs (missions/go_to.py), on the same control loop:
from the shell, a script or a test. Progress (a bar, the distance left and an ETA) goes
to standard error; `--json` prints how it went on standard output. The exit code says
whether the robot arrived: 0 yes, 1 no (stall, ESTOP, lost link, no way, interrupted),
2 a mistake in the command (an unknown room, a bad floor plan or settings).

With the simulator the loop runs on a virtual clock, `--sim-speed` times faster than
real time: every tick falls at the same virtual time whatever the speed, so a faster
clock changes nothing but how long the run takes.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
from collections.abc import Callable
from pathlib import Path

import serial

from giraff_console.clock import RealClock
from giraff_console.link import BoardLink
from giraff_console.missions.docking import DOCK, GoToPose, go_mission
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
from giraff_console.planning.room_graph import PlanningError, UnknownRoomError
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.last_stop import LastStop
from giraff_console.robot.telemetry import LinkState
from giraff_console.robot.teleop import Teleop
from giraff_console.settings import Settings
from giraff_console.sim_site import SimulatedSite
from giraff_console.simulator_options import add_firmware_option, simulator_url

EXIT_ARRIVED, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
# Seconds of real time to wait for the board's first answer.
CONNECT_TIMEOUT_S = 10.0


def add_go_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    go = commands.add_parser(
        "go",
        help="take the robot to a room of the floor plan, without the screen",
        description="Plan a route from the floor plan's start room (where the robot is "
        "taken to stand) to ROOM and drive it: clothoid turns, a jerk-limited speed "
        "profile, steering from the odometry, replanning round what the range finder "
        "sees. Progress goes to standard error. Exits 0 when the robot arrived, 1 when it "
        "did not (the reason is printed), 2 for an unknown room or a bad floor plan.",
    )
    go.add_argument(
        "room", metavar="ROOM",
        help=f"room id, e.g. kitchen; {DOCK} drives onto the dock (the start room's point, "
        "facing its heading) the last metres straight",
    )  # fmt: skip
    go.add_argument(
        "--floorplan", type=Path, default=argparse.SUPPRESS, metavar="FILE",
        help=f"floor plan YAML (default: the example care home, {example})",
    )  # fmt: skip
    go.add_argument(
        "--port", metavar="PORT|URL", default=argparse.SUPPRESS,
        help="the motor board's serial device or pyserial URL (default: from the settings "
        "file; without one, the built-in simulator)",
    )  # fmt: skip
    go.add_argument(
        "--sim", action="store_true", default=argparse.SUPPRESS,
        help="use the built-in simulator, in the floor plan's building",
    )  # fmt: skip
    go.add_argument("--json", action="store_true", help="print how it went as JSON")
    go.add_argument(
        "--sim-speed", type=float, default=argparse.SUPPRESS, metavar="K",
        help="run the simulator's clock K times faster than real time; inf for as fast as "
        "it can (default: 1)",
    )  # fmt: skip
    go.add_argument(
        "--imperfect", action="store_true",
        help="simulate a real robot's errors: distances, caster drift, stalls, ESTOP",
    )  # fmt: skip
    go.add_argument("--seed", type=int, default=1, metavar="N", help="seed for --imperfect")
    add_firmware_option(go, after_command=True)
    go.add_argument(
        "--block", action="append", default=[], metavar="X,Y",
        help="put a 0.5 m box in the simulated building at X,Y metres (repeatable)",
    )  # fmt: skip


def run_go(args: argparse.Namespace, settings: Settings, port: str | None,
           example: Path) -> int:  # fmt: skip
    """Drive to `args.room`; the exit code says how it went."""
    try:
        plan = load_floorplan(args.floorplan or example)
        navigator = Navigator(plan, walls_of(plan), settings.robot_radius)
        limits = settings.motion.limits()
        patience = settings.motion.patience()
        blocks = [_point(text) for text in args.block]
    except (FloorPlanError, OSError, ValueError) as error:
        return _fail(str(error), EXIT_USAGE)
    if args.room not in plan.rooms and args.room != DOCK:
        return _fail(f"no room called {args.room!r} (rooms: {', '.join(sorted(plan.rooms))})",
                     EXIT_USAGE)  # fmt: skip
    if args.sim_speed <= 0:
        return _fail("--sim-speed must be positive", EXIT_USAGE)
    start = navigator.start_pose
    site = None
    if port is None:
        seed = args.seed if args.imperfect else None
        url = simulator_url(args.firmware, virtual_clock=True, imperfect_seed=seed)
        simulator = serial.serial_for_url(url)
        clock = simulator.clock
        site = SimulatedSite(simulator.board, plan, start, settings.motion.sensing_range)
        for x, y in blocks:
            site.surroundings.block(x, y)

        def connect() -> BoardLink:
            if not simulator.is_open:
                simulator.open()
            link = BoardLink(simulator, timeout=settings.timeout, clock=simulator.clock)
            link.handshake(power_line="none")
            return link
    else:
        clock = RealClock()

        def connect() -> BoardLink:
            return BoardLink.open(port, timeout=settings.timeout, power_line=settings.power_line)

    control = ControlLoop(
        connect,
        teleop=Teleop(settings.teleop.limits()),
        deadman=Deadman(clock, settings.teleop.grace, settings.teleop.repeat_timeout),
        rate_hz=settings.control_rate,
        clock=clock,
        wheel_base=settings.board.wheel_base,
        odometers=settings.board.odometers,
        twm=settings.board.twm,
    )
    if start is not None:
        control.odometry.reset(start)
    control.report = lambda text: print(f"giraff-console: {text}", file=sys.stderr)
    connected = threading.Event()
    control.telemetry_observers.append(
        lambda telemetry: connected.set() if telemetry.link is LinkState.CONNECTED else None
    )
    try:
        # Planned before the loop starts, so that the simulator's clock has not moved
        # on by however long planning took.
        sense = site.range_finder.readings if site is not None else None
        mission = go_mission(navigator, args.room, lambda: control.odometry.pose,
                             tick=control.period, limits=limits, sense=sense,
                             notify=control.report, patience=patience)  # fmt: skip
    except PlanningError as error:
        return _fail(str(error), EXIT_USAGE if isinstance(error, UnknownRoomError) else EXIT_FAILED)
    # Before the loop's thread starts: SIGHUP (the SSH connection dropped), SIGTERM and
    # SIGINT stop the robot from the loop's own thread and end the mission.
    last_stop = LastStop(control)
    last_stop.install()
    control.start(stepped=args.sim_speed if site is not None else None)
    try:
        if not connected.wait(CONNECT_TIMEOUT_S):
            return _fail("no answer from the board", EXIT_FAILED)
        # The report and the true pose are taken on the loop's thread as the mission
        # ends, at a virtual time that does not depend on how fast the clock runs.
        ended: list = []
        _drive(control, mission, lambda why: ended.append(
            (mission.report(why), site.true_pose() if site is not None else None)))  # fmt: skip
    finally:
        control.stop()
        last_stop.uninstall()
    report, pose_true = ended[0]
    why = report.why
    if args.json:
        print(json.dumps(report.as_json(pose_true)))
    else:
        data = report.as_json(pose_true)
        goal = "the dock" if args.room == DOCK else "the room's point"
        print(f"{mission.name}: {why}; {data['error_m'] * 100:.1f} cm and "
              f"{data['heading_error_deg']:.1f}° from {goal}, in "
              f"{data['duration_s']:.1f} s (jerk-limited optimum "
              f"{data['time_optimal_s']:.1f} s), {len(data['stops'])} stops")  # fmt: skip
    return EXIT_ARRIVED if report.arrived else EXIT_FAILED


def _drive(control: ControlLoop, mission: GoTo | GoToPose, ended: Callable[[str], None]) -> None:
    """Run the mission to its end, showing progress; a signal stops it (LastStop).
    `ended` gets the reason, on the loop's thread."""
    done = threading.Event()

    def finish(why: str) -> None:
        ended(why)
        done.set()

    control.run_mission(mission, finish)
    tty = sys.stderr.isatty()
    while not done.wait(0.5 if tty else 5.0):
        line = mission.progress
        print(f"\r{line}\033[K" if tty else line, end="" if tty else "\n", file=sys.stderr)
    if tty:
        print(file=sys.stderr)


def _point(text: str) -> tuple[float, float]:
    try:
        x, y = (float(part) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--block wants X,Y in metres, not {text!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"--block wants finite numbers, not {text!r}")
    return x, y


def _fail(message: str, code: int) -> int:
    print(f"giraff-console: {message}", file=sys.stderr)
    return code
