"""`giraff-console` (and `giraff-console replay SESSION`): the operator's console.

On the robot in this process (runtime/robot.py, §3.2: the simulator when no board is
given), or attached to the daemon when one runs, as one more of its consoles: the same
screen either way (tui/app.py).
"""

from __future__ import annotations

import argparse
import contextlib
import gc
from collections.abc import Callable, Iterator
from pathlib import Path

from giraff_console.camera.processors import Undistortion
from giraff_console.cli.daemon import attach_if_running, daemon_robot
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.cli.options import robot_options
from giraff_console.cli.report import fail
from giraff_console.clock import RealClock
from giraff_console.planning.floorplan import FloorPlan, FloorPlanError, load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.playback import open_log
from giraff_console.recording.session import SessionError
from giraff_console.runtime.options import UsageError
from giraff_console.runtime.robot import Robot
from giraff_console.service.reattach import Reattaching
from giraff_console.service.remote import RemoteRobot
from giraff_console.service.runtime_folder import socket_path
from giraff_console.settings import Settings
from giraff_console.tui.app import GiraffConsole


def run_console(args: argparse.Namespace, settings: Settings, example: Path) -> int:
    """The operator console on a real board or the simulator (§3.2: it falls back)."""
    if args.calibration:
        try:
            Undistortion.from_file(args.calibration)
        except (OSError, ValueError) as error:
            return fail(str(error), EXIT_USAGE)
    attached = attach_if_running(args, "console", take=True)
    if isinstance(attached, int):
        return attached
    if attached is not None:
        return run_attached_console(attached, args, settings, example)
    if args.command == "replay":
        try:
            log_path, log = open_log(args.session)
        except SessionError as error:
            return fail(str(error), EXIT_USAGE)
        if not log.entries:
            return fail(f"nothing to play in {log_path}", EXIT_USAGE)
    with collected_from_first_screen() as drawn:
        try:
            robot = Robot(robot_options(args, settings, screen=True), settings, example)
        except UsageError as error:
            return fail(str(error), EXIT_USAGE)
        return run_robot_console(robot, args, settings, drawn)


def run_robot_console(robot: Robot, args: argparse.Namespace, settings: Settings,
                      drawn: Callable[[], None]) -> int:  # fmt: skip
    """The console on the robot built for it, in this process; `drawn` is told once the
    first screen has been drawn, as the robot starts."""
    plan = robot.plan

    def start() -> None:
        drawn()
        robot.start()

    with robot:
        app = GiraffConsole(
            robot.service,
            clock=robot.control.clock,
            simulator=robot.site is not None,
            camera=robot.camera,
            undock_distance=settings.teleop.undock_distance,
            battery_low=settings.battery.low,
            play=args.session if args.command == "replay" else None,
            plan=plan,
            walls=robot.navigator.walls,
            started=start,
            stop=robot.stop,
        )
        app.notes_at_start.append(plan_note(plan))
        app.notes_at_start.extend(robot.notes_at_start)
        # Signals and crashes stop the robot from the loop's own thread, then the console
        # leaves; installed before any thread starts (the loop's, the camera's).
        last_stop = robot.guard(leave=lambda why: app.exit(return_code=1))
        app.crashed = last_stop.crashed
        app.run()
    if last_stop.signalled is not None:
        return 128 + last_stop.signalled
    # Non-zero if the console itself failed; the robot was stopped all the same.
    return app.return_code or 0


@contextlib.contextmanager
def collected_from_first_screen() -> Iterator[Callable[[], None]]:
    """Python's collector off until the first screen is drawn, then on again for good,
    with what was made until then left out of its rounds (gc.freeze); on again in any
    case once the console ends. The function given says the screen is drawn.

    As with the modules the console loads (cli/main.py, load_console): the robot built for the
    console and the screen's widgets live as long as the console, and the collector
    walked them again and again as they were made, about a hundred rounds before the
    first screen (8 ms of its CPU, issue 26, item 6). What the console makes from then on
    is collected as before."""
    gc.disable()

    def drawn() -> None:
        if not gc.isenabled():
            gc.freeze()
            gc.enable()

    try:
        yield drawn
    finally:
        gc.enable()


def run_attached_console(first: RemoteRobot, args: argparse.Namespace, settings: Settings,
                         example: Path) -> int:  # fmt: skip
    """The console on a running daemon's robot: the map from the daemon's floor plan.
    Quitting, or the terminal going, leaves the daemon's missions running; a key held
    is let go of by the daemon (service/daemon.py)."""
    # Through the daemon's restarts: attached again by itself, asking for the controls
    # as at the start (service/reattach.py).
    robot = Reattaching(first, lambda: daemon_robot("console", take=True))
    welcome = robot.welcome
    plan, walls, note = None, None, "floor plan: none"
    try:
        plan = load_floorplan(welcome.floorplan or example)
        walls, note = walls_of(plan), plan_note(plan)
    except (FloorPlanError, OSError) as error:
        note = f"no map: {error}"
    app = GiraffConsole(
        robot,
        clock=RealClock(),
        simulator=welcome.simulator,
        attached=str(socket_path()),
        undock_distance=settings.teleop.undock_distance,
        battery_low=settings.battery.low,
        play=args.session if args.command == "replay" else None,
        plan=plan,
        walls=walls,
    )
    app.notes_at_start.append(note)
    app.controls = welcome.controls
    app.route = welcome.route
    app.notes_at_start.extend(app.welcomed(welcome))
    try:
        app.run()
    finally:
        robot.close()
    return app.return_code or 0


def plan_note(plan: FloorPlan) -> str:
    """What the status log says of the floor plan the console is on."""
    where = f", starting in {plan.start}" if plan.start else ""
    return f"floor plan: {plan.name} ({len(plan.rooms)} rooms){where}"
