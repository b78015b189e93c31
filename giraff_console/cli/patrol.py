"""`giraff-console patrol NAME`: run a patrol without the console's screen (issue 14).

The same patrol the console's `patrol NAME` runs (missions/patrol.py), on the same
control loop, set up as `go` is (runtime/robot.py): from the shell, a script, a test or a
benchmark (bench/localisation.py). NAME is a patrol in the routes folder
(`NAME.patrol.yaml`, routes/README.md) or the path of a patrol file; its stops go to
rooms of the floor plan or drive taught routes, which are looked for beside the patrol
file. Headless, it takes no snapshots and does not go to charge.

`--json` prints one line for each stop as the robot comes to rest there, or as the
patrol ends on the way to it: where the robot believes it is, where it really is (with
the simulator), how far that is from the stop's goal (the room's point and heading, as
`go` measures it, or the end of the route's taught path) and how well the estimate
knew it (`sigma_m`), the stop's `outcome` and its `detail` (a stop that failed says
why, and the patrol goes on to the next: missions/patrol.py); then a last line for the
patrol. The exit codes are `go`'s (cli/exit_codes.py): the patrol judges its own end, every
stop reached (confirmed or not) or a stop missed (missions/patrol.py).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/__init__.py). What
# the patrol drives with is imported when it runs (issue 26, item 6).
from giraff_console.cli.daemon import attach_if_running
from giraff_console.cli.exit_codes import EXIT_FAILED, EXIT_HELP, EXIT_USAGE, exit_code
from giraff_console.cli.options import add_folder_options, add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.data_folders import data_folder, default_routes, example_routes
from giraff_console.missions.names import PATROL_SUFFIX, list_patrols, patrol_file
from giraff_console.service import commands as c

if TYPE_CHECKING:
    from giraff_console.missions.patrol import Patrol
    from giraff_console.missions.route import Route
    from giraff_console.service.remote import RemoteRobot
    from giraff_console.settings import Settings


def add_patrol_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    patrol = commands.add_parser(
        "patrol",
        help="run a patrol without the screen",
        description="Run patrol NAME: each round, each stop in turn (a room of the floor "
        "plan, driven to as `go` drives, or a taught route), from the floor plan's start "
        "room. Progress goes to standard error; --json prints a line for each stop and one "
        "for the patrol. A stop that fails on the way (touched something again and again, "
        "or no way there) is reported and the patrol goes on to the next, unless the file "
        "says carry_on: false. Asks the daemon when one runs (giraff-console serve), "
        "which logs the run where `patrols` lists it. " + EXIT_HELP,
    )
    patrol.add_argument(
        "name", metavar="NAME",
        help=f"a patrol in the routes folder (NAME{PATROL_SUFFIX}), else one of the examples "
        f"shipped for the example floor plan ({', '.join(list_patrols(example_routes()))}), "
        "or a patrol file's path",
    )  # fmt: skip
    add_folder_options(patrol, after_command=True, recordings=False)
    add_robot_options(patrol, example)


def run_patrol(args: argparse.Namespace, settings: Settings, example: Path) -> int:
    """Run the patrol `args.name`; the exit code says how it went."""
    from giraff_console.cli.drive import print_note
    from giraff_console.cli.patrol_here import patrol_here
    from giraff_console.runtime.options import UsageError
    from giraff_console.runtime.robot import Robot

    attached = attach_if_running(args, "patrol")
    if isinstance(attached, int):
        return attached
    if attached is not None:
        # A patrol file named by its path is the daemon's to read, from its own folder.
        name = args.name
        if name.endswith(PATROL_SUFFIX):
            name = str(Path(name).resolve())
        return _on_the_daemon(attached, c.RunPatrol(name), args.json)
    try:
        patrol, routes = _load(args.name, data_folder(args.routes, settings.routes,
                                                      default_routes()))  # fmt: skip
        robot = Robot(robot_options(args, settings), settings, example, notes=print_note)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    with robot:
        return patrol_here(robot, patrol, routes, args.json)


def _on_the_daemon(remote: RemoteRobot, request: c.RunPatrol, as_json: bool) -> int:
    """The patrol run by the daemon (logged where `patrols` lists it): how it ended."""
    from giraff_console.cli.drive import drive_there
    from giraff_console.service.events import Reply

    try:
        ended = drive_there(remote, request)
    except KeyboardInterrupt:
        return 130
    if ended is None:
        return fail("the daemon has gone before the patrol ended", EXIT_FAILED)
    if isinstance(ended, Reply):
        return fail(ended.text, EXIT_FAILED)
    end = ended.end
    if as_json:
        print(json.dumps({"patrol": request.name, "outcome": end.outcome.value, "why": end.why,
                          "detail": end.detail}))  # fmt: skip
    else:
        print(f"{ended.name}: {end.words}")
    return exit_code(end)


def _load(name: str, folder: Path) -> tuple[Patrol, dict[str, Route]]:
    """The patrol NAME names and the taught routes it drives; UsageError if either
    cannot be read."""
    from giraff_console.missions.patrol import PatrolError, load_patrol
    from giraff_console.missions.route import RouteError, load_route
    from giraff_console.runtime.options import UsageError

    # The operator's own patrol of that name first, then the examples (data_folders.py).
    path = patrol_file(name, (folder, example_routes()))
    if not path.is_file():
        known = ", ".join(list_patrols(folder)) or "none"
        examples = ", ".join(list_patrols(example_routes())) or "none"
        raise UsageError(f"no patrol {name} (no file {path}; patrols in {folder}: {known}; "
                         f"examples: {examples})")  # fmt: skip
    try:
        patrol = load_patrol(path)
        routes = {stop.route: load_route(path.parent / f"{stop.route}.yaml")
                  for stop in patrol.stops if stop.route is not None}  # fmt: skip
    except (OSError, PatrolError, RouteError) as error:
        raise UsageError(str(error)) from None
    return patrol, routes
