"""`giraff-console patrol NAME`: run a patrol without the console's screen (issue 14).

The same request the console's `patrol NAME` sends, to the same service: the robot's in
this process (runtime/robot.py), or the daemon's when one runs (cli/drive.py), which
runs the patrol (missions/route_book.py) and reports it the same way to both (issue 26).
It is for the shell, a script, a test or a benchmark (bench/localisation.py). NAME is a
patrol in the routes folder (`NAME.patrol.yaml`, routes/README.md) or the path of a
patrol file; its stops go to rooms of the floor plan or drive taught routes, which are
looked for beside the patrol file. As the console's patrol, it goes to charge on a low
battery (on a board that reports its charger), and takes its snapshots with the camera:
the simulator without a screen or a daemon has none, and takes none.

`--json` prints one line for each stop as the robot comes to rest there, or as the
patrol ends on the way to it: where the robot believes it is, where it really is (with
the simulator), how far that is from the stop's goal (the room's point and heading, as
`go` measures it, or the end of the route's taught path) and how well the estimate
knew it (`sigma_m`), the stop's `outcome` and its `detail` (a stop that failed says
why, and the patrol goes on to the next: missions/patrol.py); then a last line for the
patrol (missions/patrol_report.py), the same lines with or without a daemon. The exit
codes are `go`'s (cli/exit_codes.py): the patrol judges its own end, every stop reached
(confirmed or not) or a stop missed (missions/patrol.py).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/main.py). What
# the patrol drives with is imported when it runs (issue 26, item 6).
from giraff_console.cli.daemon import attach_if_running
from giraff_console.cli.exit_codes import EXIT_HELP, EXIT_USAGE
from giraff_console.cli.options import add_folder_options, add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.data_folders import data_folder, default_routes, example_routes
from giraff_console.missions.names import PATROL_SUFFIX, list_patrols, patrol_file
from giraff_console.service import commands as c

if TYPE_CHECKING:
    from giraff_console.missions.patrol import Patrol
    from giraff_console.planning.floorplan import FloorPlan
    from giraff_console.settings import Settings

# Who the log of patrol runs says ran a patrol from the shell (`giraff-console patrols`).
PATROL_COMMAND = "the patrol command"


def add_patrol_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    patrol = commands.add_parser(
        "patrol",
        help="run a patrol without the screen",
        description="Run patrol NAME: each round, each stop in turn (a room of the floor "
        "plan, driven to as `go` drives, or a taught route), from the floor plan's start "
        "room. Progress goes to standard error; a line for each stop as it ends, and one "
        "for the patrol, to standard output (--json: the same keys with or without a "
        "daemon). A stop that fails on the way (touched something again and again, "
        "or no way there) is reported and the patrol goes on to the next, unless the file "
        "says carry_on: false. Asks the daemon when one runs (giraff-console serve); "
        "either way the run is logged where `patrols` lists it. " + EXIT_HELP,
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
    from giraff_console.cli.drive import drive_here, drive_there, mission_name, print_note
    from giraff_console.cli.patrol_lines import PatrolLines
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
        request = c.RunPatrol(name)
        lines = PatrolLines(mission_name(request), args.json)
        try:
            ended = drive_there(attached, request, also=lines.heard)
        except KeyboardInterrupt:
            return 130
        return lines.ended(ended, gone="the daemon has gone before the patrol ended")
    try:
        path, patrol = _load(args.name, data_folder(args.routes, settings.routes,
                                                    default_routes()))  # fmt: skip
        robot = Robot(robot_options(args, settings), settings, example, notes=print_note)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    with robot:
        unknown = _no_rooms(patrol, robot.plan)
        if unknown is not None:
            return fail(unknown, EXIT_USAGE)
        # Asked of the robot's service as the daemon's is: it runs the patrol, plans its
        # first leg as the board first answers, and reports each stop; the run is logged
        # where `giraff-console patrols` lists it, by this command (issue 26).
        robot.service.attach(PATROL_COMMAND)
        request = c.RunPatrol(str(path.resolve()))
        lines = PatrolLines(patrol.name, args.json)
        ended = drive_here(robot, request, also=lines.heard, console=PATROL_COMMAND)
        return lines.ended(ended, gone="no answer from the board")


def _no_rooms(patrol: Patrol, plan: FloorPlan) -> str | None:
    """What to say of the rooms `patrol` stops at that `plan` does not have; None if it
    has them all (the dock is the start room's, if the plan has one)."""
    from giraff_console.missions.names import DOCK

    known = {DOCK} if plan.start is not None else set()
    unknown = sorted({s.room for s in patrol.stops if s.room and s.room not in plan.rooms} - known)
    if not unknown:
        return None
    return f"patrol {patrol.name}: " + "; ".join(plan.no_room(room, also=known) for room in unknown)


def _load(name: str, folder: Path) -> tuple[Path, Patrol]:
    """The file of the patrol NAME names, and the patrol; UsageError if it, or a taught
    route it drives (looked for beside it), cannot be read."""
    from giraff_console.missions.patrol import PatrolError, load_patrol
    from giraff_console.missions.route import RouteError, load_route
    from giraff_console.runtime.options import UsageError

    # The operator's own patrol of that name first, then the examples (data_folders.py).
    path = patrol_file(name, (folder, example_routes()))
    if not path.exists():  # a FIFO or a device is refused by load_patrol
        known = ", ".join(list_patrols(folder)) or "none"
        examples = ", ".join(list_patrols(example_routes())) or "none"
        raise UsageError(f"no patrol {name} (no file {path}; patrols in {folder}: {known}; "
                         f"examples: {examples})")  # fmt: skip
    try:
        patrol = load_patrol(path)
        for stop in patrol.stops:
            if stop.route is not None:
                load_route(path.parent / f"{stop.route}.yaml")
    except (OSError, PatrolError, RouteError) as error:
        raise UsageError(str(error)) from None
    return path, patrol
