"""`giraff-console go ROOM`: take the robot to a room without the console's screen.

`go dock` drives onto the dock, square on (missions/docking.py).

The same request the console's `go` sends, to the same service: the robot's in this
process (runtime/robot.py), or the daemon's when one runs (cli/drive.py). Either way
progress goes to standard error, and how it went to standard output, the same words
and the same `--json` keys (GoReport, missions/go_to.py); the exit code says how it
ended (exit_codes.EXIT_HELP).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/main.py). What
# `go` drives with is imported when it runs (issue 26, item 6).
from giraff_console.cli.daemon import attach_if_running
from giraff_console.cli.exit_codes import EXIT_FAILED, EXIT_HELP, EXIT_USAGE
from giraff_console.cli.options import add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.missions.names import DOCK
from giraff_console.service import commands as c

if TYPE_CHECKING:
    from giraff_console.cli.drive import Ended
    from giraff_console.robot.mission import MissionEnd
    from giraff_console.service.events import Reply
    from giraff_console.settings import Settings


def add_go_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    go = commands.add_parser(
        "go",
        help="take the robot to a room of the floor plan, without the screen",
        description="Plan a route from where the robot stands (the floor plan's start "
        "room at first) to ROOM and drive it: clothoid turns, a jerk-limited speed "
        "profile, steering from the pose estimate (the odometry corrected by the plan's "
        "markers), replanning round what the range finder sees. Asks the daemon when one "
        "runs (giraff-console serve). Progress goes to standard error; how it went to "
        "standard output (--json: the same keys with or without a daemon). " + EXIT_HELP,
    )
    go.add_argument(
        "room", metavar="ROOM",
        help=f"room id, e.g. kitchen; {DOCK} drives onto the dock (the start room's point, "
        "facing its heading) the last metres straight",
    )  # fmt: skip
    add_robot_options(go, example)


def run_go(args: argparse.Namespace, settings: Settings, example: Path) -> int:
    """Drive to `args.room`; the exit code says how it went."""
    from giraff_console.cli.drive import drive_here, drive_there, print_note
    from giraff_console.runtime.options import UsageError
    from giraff_console.runtime.robot import Robot

    request = c.Go(args.room)
    attached = attach_if_running(args, "go")
    if isinstance(attached, int):
        return attached
    if attached is not None:
        # A room the daemon's plan does not have is a mistake in the command, as it is
        # without a daemon: said the same way, before anything is asked.
        unknown = _no_room(attached.welcome.floorplan, args.room)
        if unknown is not None:
            attached.close()
            return fail(unknown, EXIT_USAGE)
        try:
            return _said(request, drive_there(attached, request), args.json)
        except KeyboardInterrupt:
            return 130
    try:
        robot = Robot(robot_options(args, settings), settings, example, notes=print_note)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    with robot:
        plan = robot.plan
        if args.room not in plan.rooms and args.room != DOCK:
            return fail(plan.no_room(args.room, also=[DOCK]), EXIT_USAGE)
        return _said(request, drive_here(robot, request), args.json)


def _no_room(floorplan: Path | None, room: str) -> str | None:
    """What to say of `room` if the daemon's floor plan has no such room; None if it
    has, or if the plan cannot be read here (the daemon says then)."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan

    if floorplan is None or room == DOCK:
        return None
    try:
        plan = load_floorplan(floorplan)
    except (FloorPlanError, OSError):
        return None
    return None if room in plan.rooms else plan.no_room(room, also=[DOCK])


def _without_report(request: c.Go, end: MissionEnd) -> dict:
    """`go --json`'s keys for a go with no report (refused, or its report lost): how it
    ended, and null for every figure."""
    from giraff_console.missions.go_to import GO_JSON_KEYS

    return dict.fromkeys(GO_JSON_KEYS) | {
        "arrived": False, "outcome": end.outcome.value, "room": request.room,
        "why": end.why, "detail": end.detail,
    }  # fmt: skip


def _said(request: c.Go, ended: Ended | Reply | None, as_json: bool) -> int:
    """Say how the go ended, on standard output; its exit code."""
    from giraff_console.cli.outcome_codes import EXIT_CODES, exit_code
    from giraff_console.robot.mission import MissionEnd, Outcome
    from giraff_console.service.events import Reply

    if ended is None:
        return fail("no answer from the board, or the daemon went", EXIT_FAILED)
    if isinstance(ended, Reply):
        # Refused before it started: how it would have ended, and the same keys.
        outcome = ended.refused or Outcome.REFUSED
        if as_json:
            print(json.dumps(_without_report(request, MissionEnd(outcome, "refused", ended.text))))
        return fail(ended.text, EXIT_CODES[outcome])
    report = ended.report
    if report is None:
        # The end came, but not the report (drive.follow): say the end, the same keys.
        end = ended.end
        if as_json:
            print(json.dumps(_without_report(request, end)))
        else:
            print(f"{ended.name}: {end.words}")
        return exit_code(end)
    data = report.as_json()
    if as_json:
        print(json.dumps(data))
    else:
        goal = "the dock" if request.room == DOCK else "the room's point"
        print(f"{ended.name}: {report.end.words}; {data['error_m'] * 100:.1f} cm and "
              f"{data['heading_error_deg']:.1f}° from {goal}, in "
              f"{data['duration_s']:.1f} s (jerk-limited optimum "
              f"{data['time_optimal_s']:.1f} s), {len(data['stops'])} stops")  # fmt: skip
    return exit_code(report.end)
