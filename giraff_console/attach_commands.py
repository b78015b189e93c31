"""The commands that talk to a running daemon: `status`, `stop`, and `go` and `patrol`
when one runs (issue 15).

Each attaches as a console that does not ask for the controls: `status` and `stop`
never need them (anyone may stop the robot), and `go` and `patrol` take them only if
nobody holds them, like any console that moves the robot (service/robot_service.py).
A mission started here belongs to the daemon: if this command's terminal goes (an SSH
session dropped), the mission carries on; Ctrl-C stops it, as it does `go` on its own.
"""

from __future__ import annotations

import argparse
import json
import queue
import sys
import time
from dataclasses import asdict
from pathlib import Path

from giraff_console.data_folders import patrol_runs
from giraff_console.missions.patrol_log import list_runs
from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.robot.mission import Outcome
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.events import ServiceEvent
from giraff_console.service.remote import DaemonGone, RemoteRobot, console_name
from giraff_console.service.runtime_folder import socket_path
from giraff_console.service.transport import NoDaemon, TransportError

EXIT_DONE, EXIT_FAILED, EXIT_NO_DAEMON = 0, 1, 3
# `go` through a daemon ends as `go` does on its own (headless.py): 3, arrived with a
# pose nothing confirmed. (`status` and `stop` have no mission: their 3 is no daemon.)
EXIT_UNVERIFIED = 3
# Seconds between lines of progress when standard error is not a terminal.
PROGRESS_EVERY_S = 5.0


def add_daemon_parsers(commands: argparse._SubParsersAction) -> None:
    status = commands.add_parser(
        "status",
        help="what the robot's daemon is doing",
        description="Ask the running daemon (giraff-console serve) what runs, who holds "
        "the controls, which consoles are attached, and how the last mission ended. "
        "Exits 3 when no daemon runs.",
    )
    status.add_argument("--json", action="store_true", help="print it as JSON")
    stop = commands.add_parser(
        "stop",
        help="stop the robot now (and, with --daemon, the daemon)",
        description="Stop the robot the daemon runs: let go of the keys, end the mission, "
        "stop the wheels. Anyone may, whoever holds the controls. Exits 3 when no daemon "
        "runs.",
    )
    stop.add_argument(
        "--daemon", action="store_true",
        help="then end the daemon too (as systemctl --user stop does)",
    )  # fmt: skip
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


def daemon_robot(kind: str, take: bool = False) -> RemoteRobot:
    """The running daemon's robot, attached as a console of `kind` that asks for the
    controls only if `take`. NoDaemon when none answers (no socket, or one left by a
    daemon that died); TransportError for one that is there but cannot be used."""
    try:
        return RemoteRobot(socket_path(), console_name(kind), take=take)
    except DaemonGone as error:
        raise TransportError(str(error)) from None


def run_status(args: argparse.Namespace) -> int:
    robot = _attach("status")
    if robot is None:
        return EXIT_NO_DAEMON
    robot.close()
    situation = robot.welcome.situation
    # The console asking is attached too; it is not one of those it reports.
    consoles = [name for name in situation.consoles if name != robot.console]
    if args.json:
        last = situation.last_mission
        ended = None
        if last is not None and last.end is not None:
            # An outcome is printed as `go --json` prints it: its value.
            ended = {"name": last.name, "running": False, "outcome": last.end.outcome.value,
                     "why": last.end.why, "detail": last.end.detail}  # fmt: skip
        data = asdict(situation) | {"consoles": consoles, "socket": str(socket_path()),
                                    "last_mission": ended}  # fmt: skip
        print(json.dumps(data))
        return EXIT_DONE
    last = situation.last_mission
    print(f"mission: {situation.mission or 'none'}")
    print(f"controls: {situation.holder or 'free'}; consoles: {', '.join(consoles) or 'none'}")
    print(f"last mission: {f'{last.name}: {last.end.words}' if last and last.end else 'none'}")
    if situation.recording or situation.playing:
        print("recording" if situation.recording else "playing back")
    return EXIT_DONE


def run_stop(args: argparse.Namespace) -> int:
    robot = _attach("stop")
    if robot is None:
        return EXIT_NO_DAEMON
    try:
        reply = robot.execute(c.Shutdown() if args.daemon else c.Halt())
    finally:
        robot.close()
    print(f"giraff-console: {reply.text or 'stopped'}", file=sys.stderr)
    return EXIT_DONE if reply.ok else EXIT_FAILED


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


def run_mission(robot: RemoteRobot, request: c.Go | c.RunPatrol, as_json: bool) -> int:
    """Start `request` on the daemon and follow it to its end: its notes and progress on
    standard error, how it ended on standard output; 0 when it was done."""
    events: queue.Queue[ServiceEvent] = queue.Queue()
    robot.subscribe(events.put)
    try:
        reply = robot.execute(request)
        name = f"go {request.room}" if isinstance(request, c.Go) else request.name
        if not reply.ok:
            _print_notes(events)  # why, if the daemon said it in a note
            print(f"giraff-console: {reply.text}", file=sys.stderr)
            if as_json:  # never started: no outcome, and why
                print(json.dumps({"mission": name, "arrived": False, "outcome": None,
                                  "why": "refused", "detail": reply.text}))  # fmt: skip
            return EXIT_FAILED
        if reply.text:
            print(f"giraff-console: {reply.text}", file=sys.stderr)
        ended = _follow(events, robot, name)
    except KeyboardInterrupt:
        # A stop, which also ends a mission still being planned (RobotService).
        stopped = robot.execute(c.Halt(), timeout=2.0)
        print(f"giraff-console: {'stopped' if stopped.ok else stopped.text} (Ctrl-C)",
              file=sys.stderr)  # fmt: skip
        return 130
    finally:
        robot.close()
    if ended is None:
        print("giraff-console: the daemon has gone before the mission ended", file=sys.stderr)
        return EXIT_FAILED
    end = ended.end
    assert end is not None  # _follow returns an end
    outcome = end.outcome
    if isinstance(request, c.Go):
        # A go says how it ended: arrived only with its pose confirmed (issue 25).
        arrived = outcome is Outcome.ARRIVED
        code = EXIT_DONE if arrived else EXIT_UNVERIFIED if outcome.arrived else EXIT_FAILED
    else:
        arrived = outcome is Outcome.DONE
        code = EXIT_DONE if arrived else EXIT_FAILED
    if as_json:
        # What the daemon tells of a mission: not the poses and errors `go` measures on
        # its own (docs/daemon.md).
        print(json.dumps({"mission": ended.name, "arrived": arrived,
                          "outcome": outcome.value, "why": end.why,
                          "detail": end.detail}))  # fmt: skip
    else:
        print(f"{ended.name}: {end.words}")
    return code


def _print_notes(events: queue.Queue[ServiceEvent]) -> None:
    while not events.empty():
        event = events.get_nowait()
        if isinstance(event, Note):
            print(f"giraff-console: {event.text}", file=sys.stderr)


def _follow(events: queue.Queue[ServiceEvent], robot: RemoteRobot,
            name: str) -> MissionChanged | None:  # fmt: skip
    """The end of the mission `name` once it has started, or None if the daemon goes
    first; another mission's end (one this one replaced) is not it."""
    started = False
    shown_at = time.monotonic()
    while robot.gone is None:
        try:
            event = events.get(timeout=1.0)
        except queue.Empty:
            continue
        if isinstance(event, Note):
            print(f"giraff-console: {event.text}", file=sys.stderr)
        elif isinstance(event, MissionChanged) and event.name == name:
            if event.running:
                started = True
            elif started or (event.end is not None
                             and event.end.outcome is Outcome.NOT_STARTED):  # fmt: skip
                return event
        elif (isinstance(event, Telemetry) and event.mission is not None
              and time.monotonic() - shown_at >= PROGRESS_EVERY_S):  # fmt: skip
            shown_at = time.monotonic()
            progress = event.mission
            left = f", {progress.left_m:.1f} m left" if progress.left_m is not None else ""
            print(f"giraff-console: {progress.name}: {progress.state}{left}", file=sys.stderr)
    return None


def _attach(kind: str) -> RemoteRobot | None:
    try:
        return daemon_robot(kind)
    except NoDaemon as error:
        print(f"giraff-console: {error}; `giraff-console serve` starts one", file=sys.stderr)
    except TransportError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
    return None
