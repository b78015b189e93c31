"""The commands that talk to a running daemon: `status`, `stop` and `patrols`; and how
`go` and `patrol` find the daemon when one runs (issue 15).

Each attaches as a console that does not ask for the controls: `status` and `stop`
never need them (anyone may stop the robot), and `go` and `patrol` take them only if
nobody holds them, like any console that moves the robot (service/robot_service.py).
A mission started here belongs to the daemon: if this command's terminal goes (an SSH
session dropped), the mission carries on; Ctrl-C stops it, as it does `go` on its own.
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from giraff_console.cli.exit_codes import EXIT_DONE, EXIT_FAILED, EXIT_NO_DAEMON, EXIT_USAGE
from giraff_console.cli.stop import add_stop_parser
from giraff_console.data_folders import patrol_runs
from giraff_console.missions.patrol_log import list_runs
from giraff_console.robot.last_stop import SIGNALS
from giraff_console.service.runtime_folder import socket_path
from giraff_console.service.transport import NoDaemon, TransportError

if TYPE_CHECKING:
    from giraff_console.service.events import ServiceEvent
    from giraff_console.service.remote import RemoteRobot

# Events `watch` holds for a reader slower than the robot.
WATCH_QUEUE = 1000


def add_daemon_parsers(commands: argparse._SubParsersAction) -> None:
    status = commands.add_parser(
        "status",
        help="what the robot's daemon is doing",
        description="Ask the running daemon (giraff-console serve) what runs, who holds "
        "the controls, which consoles are attached, and how the last mission ended. "
        "Exits 3 when no daemon runs.",
    )
    status.add_argument("--json", action="store_true", help="print it as JSON")
    add_stop_parser(commands)
    patrols = commands.add_parser(
        "patrols",
        help="the log of patrol runs, newest first",
        description=f"List the patrol runs logged in {patrol_runs()}, newest first: who "
        "started each (a console or the schedule), when, how many stops it reached and why "
        "it ended; a scheduled slot that was skipped, and why. A run without an end is "
        "`running` while the daemon has it under way, else `unfinished`.",
    )
    patrols.add_argument("--json", action="store_true", help="one JSON object a line")
    patrols.add_argument("--last", type=int, metavar="N", help="only the N newest")
    watch = commands.add_parser(
        "watch",
        help="follow what the robot's daemon says, as it says it",
        description="Attach to the running daemon as a console that does not ask for the "
        "controls, and print what the robot says until Ctrl-C: its notes, missions "
        "starting and ending, and (with --json) every event as one JSON object a line, "
        "tagged with its type as the daemon's socket carries it (docs/daemon.md), but "
        "the loop's own polls of the board. "
        "Exits 0 on Ctrl-C, 1 when the daemon goes, 3 when none runs.",
    )
    watch.add_argument("--json", action="store_true", help="every event, one JSON object a line")
    watch.add_argument(
        "--telemetry-hz", type=float, default=2.0, metavar="HZ",
        help="at most this many snapshots a second (the loop makes 20; default: %(default)g)",
    )  # fmt: skip


def daemon_robot(kind: str, take: bool = False) -> RemoteRobot:
    """The running daemon's robot, attached as a console of `kind` that asks for the
    controls only if `take`. NoDaemon when none answers (no socket, or one left by a
    daemon that died); TransportError for one that is there but cannot be used."""
    # Imported here, not with the parsers: it loads the robot's types (issue 26, item 6).
    from giraff_console.service.console_name import console_name
    from giraff_console.service.remote import DaemonGone, RemoteRobot

    try:
        return RemoteRobot(socket_path(), console_name(kind), take=take)
    except DaemonGone as error:
        raise TransportError(str(error)) from None


def run_status(args: argparse.Namespace) -> int:
    from giraff_console.service.status import status_json, status_lines

    robot = _attach("status")
    if robot is None:
        return EXIT_NO_DAEMON
    robot.close()
    situation = robot.welcome.situation
    # The console asking is attached too; it is not one of those it reports.
    consoles = tuple(name for name in situation.consoles if name != robot.console)
    if args.json:
        print(json.dumps(status_json(situation, consoles) | {"socket": str(socket_path())}))
    else:
        for line in status_lines(situation, consoles):
            print(line)
    return EXIT_DONE


def run_watch(args: argparse.Namespace) -> int:
    from giraff_console.link import Exchange
    from giraff_console.robot.telemetry import Telemetry

    if not args.telemetry_hz > 0:
        print("giraff-console: --telemetry-hz must be positive", file=sys.stderr)
        return EXIT_USAGE
    robot = _attach("watch")
    if robot is None:
        return EXIT_NO_DAEMON
    # Bounded: a reader that cannot keep up (a pipe nobody reads) loses events, counted,
    # rather than the daemon's memory or this process's.
    events: queue.Queue[ServiceEvent] = queue.Queue(maxsize=WATCH_QUEUE)
    dropped = 0

    def heard(event: ServiceEvent) -> None:
        nonlocal dropped
        try:
            events.put_nowait(event)
        except queue.Full:
            dropped += 1

    robot.subscribe(heard)
    every, shown_at = 1.0 / args.telemetry_hz, -math.inf
    try:
        while robot.gone is None or not events.empty():
            try:
                event = events.get(timeout=0.5)
            except queue.Empty:
                continue
            if isinstance(event, Exchange) and event.automatic:
                continue  # the loop's own polls, twenty a second: the snapshots say them
            if isinstance(event, Telemetry):
                if time.monotonic() - shown_at < every:
                    continue
                shown_at = time.monotonic()
            _say(event, args.json)
            if dropped:
                print(json.dumps({"type": "Dropped", "events": dropped}) if args.json else
                      f"giraff-console: {dropped} events dropped: not read fast enough",
                      flush=True)  # fmt: skip
                dropped = 0
    except KeyboardInterrupt:
        # Ctrl-C ends it; what was heard before is still said, and a second Ctrl-C does
        # not cut the hang-up short.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        while not events.empty():
            event = events.get_nowait()
            if not isinstance(event, Telemetry | Exchange):
                _say(event, args.json)
        return EXIT_DONE
    finally:
        robot.close()
    print(f"giraff-console: {robot.gone}", file=sys.stderr)
    return EXIT_FAILED


def _say(event: ServiceEvent, as_json: bool) -> None:
    """One event: as the socket carries it, or in words where it has any."""
    from giraff_console.robot.loop_events import MissionChanged, Note
    from giraff_console.robot.telemetry import Telemetry
    from giraff_console.service import wire

    if as_json:
        print(json.dumps(wire.encode(event)), flush=True)
    elif isinstance(event, Note):
        print(event.text, flush=True)
    elif isinstance(event, MissionChanged):
        said = "started" if event.end is None else f"ended: {event.end.words}"
        print(f"{event.name} {said}", flush=True)
    elif isinstance(event, Telemetry) and event.mission is not None:
        print(event.mission.line(), flush=True)


def run_patrols(args: argparse.Namespace) -> int:
    folder = patrol_runs()
    running = None
    try:
        robot: RemoteRobot | None = daemon_robot("patrols")
    except TransportError:  # NoDaemon too: the log is read all the same
        robot = None
    if robot is not None:
        robot.close()
        mission = robot.welcome.situation.mission
        unfinished = [run for run in list_runs(folder) if run.state == "unfinished"]
        running = next((Path(run.file) for run in unfinished if run.patrol == mission), None)
    runs = list_runs(folder, args.last, running)
    if args.json:
        for run in runs:
            print(json.dumps(run.to_json()))
        return EXIT_DONE
    if not runs:
        print(f"no patrol runs logged in {folder}")
    for run in runs:
        print(run.line())
    return EXIT_DONE


def _attach(kind: str) -> RemoteRobot | None:
    try:
        return daemon_robot(kind)
    except NoDaemon as error:
        print(f"giraff-console: {error}; `giraff-console serve` starts one", file=sys.stderr)
    except TransportError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
    return None


def attach_if_running(args: argparse.Namespace, kind: str,
                      take: bool = False) -> RemoteRobot | int | None:  # fmt: skip
    """The running daemon's robot for a command that drives, unless it asks for a
    simulator of its own (--sim); None when no daemon runs; an exit code when one does
    but the command names a board of its own (the daemon has it) or it cannot be used.
    The command's signals are its own again: the daemon stops the robot, not it."""
    if getattr(args, "sim", False):
        return None
    try:
        robot = daemon_robot(kind, take=take)
    except NoDaemon:
        return None
    except TransportError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    if getattr(args, "port", None) is not None:
        robot.close()
        print(f"giraff-console: the daemon at {socket_path()} has the robot; leave out "
              "--port to ask it, or stop it (giraff-console stop --daemon)",
              file=sys.stderr)  # fmt: skip
        return EXIT_USAGE
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)
    print(f"giraff-console: asking the daemon at {socket_path()}", file=sys.stderr)
    ignored = [f"--{name}" for name in ("floorplan", "routes", "recordings", "at", "camera",
                                        "calibration")
               if getattr(args, name, None) is not None]  # fmt: skip
    if ignored:
        print(f"giraff-console: {', '.join(ignored)} ignored: the daemon's are used",
              file=sys.stderr)  # fmt: skip
    return robot
