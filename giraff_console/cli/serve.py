"""`giraff-console serve`: the daemon that owns the robot (issue 15).

It gets its robot as `go` and `patrol` do (runtime/robot.py: the floor plan, the board
or the simulator in the plan's building, the control loop, the markers, the route book
and the recordings, the service on them) and serves that RobotService on a Unix socket
in the user's runtime folder. Consoles attach and leave; the robot, its missions and its
patrols stay with the daemon, so closing an SSH session no longer ends the night's
patrol.

SIGTERM and SIGINT stop the robot from the loop's own thread before the daemon ends
(robot/last_stop.py), as they do for the console. SIGHUP does not: the daemon has no
terminal, and one started by hand from an SSH session is there to outlive it. Its notes
go to standard error, where systemd's journal keeps them (docs/daemon.md).
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import queue
import resource
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/main.py). What
# the daemon runs is imported when it runs (issue 26, item 6).
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.cli.options import add_folder_options, add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.robot.last_stop import SIGNALS
from giraff_console.service.runtime_folder import runtime_folder, socket_path
from giraff_console.service.transport import TransportError

if TYPE_CHECKING:
    from giraff_console.fleet.vehicle import FleetVehicle
    from giraff_console.robot.loop_events import LoopEvent
    from giraff_console.runtime.robot import Robot
    from giraff_console.service.robot_service import RobotService
    from giraff_console.settings import Settings


class Journal:
    """The loop's notes on standard error (systemd's journal), written by a thread of
    their own: the loop only queues them, since a journal that stalls, or a pipe that
    nobody reads, must not stop the loop. A note that finds the queue full is lost."""

    def __init__(self, size: int = 1000) -> None:
        self._notes: queue.Queue[str | None] = queue.Queue(size)
        self._thread = threading.Thread(target=self._write, name="journal", daemon=True)
        self._thread.start()

    def hear(self, event: LoopEvent) -> None:
        # Loaded by the robot before any event: the import only looks it up.
        from giraff_console.robot.loop_events import Note

        if isinstance(event, Note):
            with contextlib.suppress(queue.Full):
                self._notes.put_nowait(f"giraff-console: {event.text}\n")

    def close(self, timeout: float = 1.0) -> None:
        with contextlib.suppress(queue.Full):
            self._notes.put(None, timeout=timeout)
        self._thread.join(timeout)

    def _write(self) -> None:
        while (line := self._notes.get()) is not None:
            with contextlib.suppress(OSError, ValueError):  # a terminal gone: go on
                sys.stderr.write(line)
                sys.stderr.flush()


def add_serve_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    serve = commands.add_parser(
        "serve",
        help="run the robot as a daemon that consoles attach to",
        description="Own the board and run the control loop, missions, patrols and "
        "recordings as a daemon. Consoles attach over a Unix socket in the runtime folder "
        "($XDG_RUNTIME_DIR/giraff-console/robot.sock, owner only; nothing listens on the "
        "network): `giraff-console` with a daemon running attaches to it, and `status`, "
        "`stop`, `go` and `patrol` ask it. A patrol started from a console carries on "
        "when the console's SSH session ends. SIGTERM stops the robot and the daemon.",
    )
    add_robot_options(serve, example, json=False)
    serve.add_argument(
        "--virtual-port", action="store_true",
        help="also give another program a pseudo-terminal that speaks the board's protocol "
        "(its path is printed): it may read while a mission runs, but not move the robot "
        "(§4.5)",
    )  # fmt: skip
    serve.add_argument(
        "--fleet", metavar="URL",
        help="also join a fleet as a VDA 5050 2.1 vehicle on the MQTT broker at URL "
        "(mqtt://HOST[:PORT], or mqtts:// for TLS), as the [fleet] settings say otherwise "
        "(docs/fleet.md): orders become missions, and the operator's console always wins",
    )  # fmt: skip
    serve.add_argument(
        "--serial-number", metavar="NAME",
        help="the vehicle's serial number on the broker (default: fleet.serial_number, "
        "else the host name)",
    )  # fmt: skip
    serve.add_argument(
        "--max-consoles", type=_consoles, metavar="N",
        help="consoles attached at once at most (default: the settings' max_consoles, 64); "
        "one more is refused, but "
        "`giraff-console stop` is still obeyed",
    )  # fmt: skip
    add_folder_options(serve, after_command=True)


def _consoles(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise argparse.ArgumentTypeError(f"a whole number of consoles, 1 or more, not {text!r}")
    return count


def run_serve(args: argparse.Namespace, settings: Settings, example: Path) -> int:
    """Serve the robot until a signal ends the daemon."""
    from giraff_console.runtime.options import UsageError
    from giraff_console.runtime.robot import Robot

    journal = Journal()
    try:
        # The journal hears the notes from the start: where the robot is taken to be,
        # and what the camera can do, are said as it is set up.
        options = robot_options(args, settings, shares_camera=True,
                                virtual_port=args.virtual_port)  # fmt: skip
        robot = Robot(options, settings, example, notes=journal.hear)
    except UsageError as error:
        journal.close()
        return fail(str(error), EXIT_USAGE)
    try:
        with robot:
            return _serve(robot, args, settings, example)
    finally:
        journal.close()  # after the robot's last notes


def _serve(robot: Robot, args: argparse.Namespace, settings: Settings, example: Path) -> int:
    from giraff_console.service.daemon import SWITCH_INTERVAL_S, Daemon, descriptors_for
    from giraff_console.service.patrol_schedule import PatrolSchedule

    service, control = robot.service, robot.control
    # Before the socket is made: nothing is left to take down for a broker it cannot use.
    try:
        fleet = _fleet(service, args, settings)
    except ValueError as error:  # BrokerError, a serial number that cannot be a topic
        return fail(f"--fleet: {error}", EXIT_USAGE)
    max_consoles = args.max_consoles or settings.max_consoles
    # Every console is a file descriptor: out of them, the daemon can only refuse the
    # newest, `stop` perhaps. So the limit is raised as far as the system lets this
    # process, and a console limit it cannot keep is refused now.
    may_open = _descriptors_raised()
    if descriptors_for(max_consoles) > may_open:
        return fail(f"max_consoles {max_consoles} needs up to {descriptors_for(max_consoles)} "
                    f"file descriptors, and this process may open {may_open} (ulimit -n)",
                    EXIT_USAGE)  # fmt: skip
    try:
        path = socket_path(runtime_folder())
        daemon = Daemon(service, path, (args.floorplan or example).resolve(),
                        simulator=robot.site is not None,
                        max_consoles=max_consoles)  # fmt: skip
    except TransportError as error:
        return fail(str(error), EXIT_USAGE)
    schedule = PatrolSchedule(service, settings.schedule, robot.routes.runs)
    port_for_others = robot.port
    # Before any thread starts: a signal stops the robot from the loop's own thread,
    # then the daemon stops taking consoles and ends.
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    last_stop = robot.guard(leave=lambda why: daemon.stop(), signals=SIGNALS - {signal.SIGHUP})
    # The control loop's tick must not wait long for the interpreter behind the consoles'
    # event loop (daemon.py): switched to more often than Python's default.
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    robot.start()
    sys.stderr.write(f"giraff-console: serving the robot at {path}\n")
    if robot.stepped is None:
        sys.stderr.write(f"giraff-console: the control loop runs at {control.priority}\n")
    sys.stderr.flush()
    if port_for_others is not None:
        # On standard output, alone, for a script to read.
        print(port_for_others.path, flush=True)
        sys.stderr.write(f"giraff-console: virtual motor port at {port_for_others.path}\n")
        sys.stderr.flush()
    schedule.start()
    if fleet is not None:
        fleet.start()
    # What was made until now (the modules, the plan, the robot) lives as long as the
    # daemon: left out of the collector's rounds for good. A full round over all of it
    # held the interpreter 20-45 ms, and the control loop's tick waited that long
    # behind it (issue 30: 0 ticks later than 5 ms); what is made from now on is
    # collected as before.
    gc.freeze()
    try:
        daemon.serve_forever()
        daemon.join(2.0)  # the consoles hear that it ends
    finally:
        daemon.stop()
        schedule.stop()
        if fleet is not None:
            fleet.close()
        if port_for_others is not None:
            port_for_others.close()
    return 128 + last_stop.signalled if last_stop.signalled is not None else 0


def _fleet(
    service: RobotService, args: argparse.Namespace, settings: Settings
) -> FleetVehicle | None:
    """The fleet link the options or the settings ask for, or None."""
    url = args.fleet or settings.fleet.broker
    if not url:
        return None
    from giraff_console.fleet.broker_link import Broker
    from giraff_console.fleet.topics import VehicleId
    from giraff_console.fleet.vehicle import FleetVehicle, serial_number

    fleet = settings.fleet
    broker = Broker.parse(
        url,
        ca_file=Path(fleet.ca_file) if fleet.ca_file else None,
        credentials=Path(fleet.credentials) if fleet.credentials else None,
    )
    vehicle = VehicleId(
        fleet.manufacturer, args.serial_number or serial_number(settings), fleet.interface
    )
    return FleetVehicle(service, broker, vehicle, settings)


def _descriptors_raised() -> int:
    """The soft limit on open files raised to the hard one (a login session's soft 1024
    under a hard limit of thousands); what it is now."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != hard:
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
    return sys.maxsize if soft == resource.RLIM_INFINITY else soft
