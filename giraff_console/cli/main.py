"""The `giraff-console` command line: the parser, and which command runs; each command
lives in its own module beside this one."""

from __future__ import annotations

import argparse
import gc
import os
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
    run_watch,
)
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.cli.export import add_export_parser, run_export
from giraff_console.cli.fleet import add_fleet_parser, run_fleet
from giraff_console.cli.floorplan import add_floorplan_parser, run_floorplan
from giraff_console.cli.go import add_go_parser, run_go
from giraff_console.cli.options import add_board_options, add_folder_options
from giraff_console.cli.patrol import add_patrol_parser, run_patrol
from giraff_console.cli.plan import add_plan_parser, run_plan
from giraff_console.cli.send import add_send_parser, run_send
from giraff_console.cli.serve import add_serve_parser, run_serve
from giraff_console.cli.sim import add_sim_parser, run_sim
from giraff_console.cli.stop import run_stop
from giraff_console.cli.survey import add_survey_parser, run_survey
from giraff_console.data_folders import config_path, example_floorplan
from giraff_console.robot.last_stop import SIGNALS

if TYPE_CHECKING:
    from giraff_console.settings import Settings


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

    add_sim_parser(commands)

    replay = commands.add_parser(
        "replay",
        help="open the console and play a recorded session back",
        description="Open the console and play SESSION back: the transcript, the pose and "
        "the video as they were recorded, at the recorded speed. Nothing is sent to the "
        "robot. k pauses, . steps, j and l seek, < and > change the speed, p returns to "
        "live. SESSION is a recordings/ directory, or a log written by the original console.",
    )
    replay.add_argument("session", type=Path, metavar="SESSION")

    add_export_parser(commands)
    add_plan_parser(commands, EXAMPLE_FLOORPLAN)
    add_floorplan_parser(commands, EXAMPLE_FLOORPLAN)
    add_go_parser(commands, EXAMPLE_FLOORPLAN)
    add_patrol_parser(commands, EXAMPLE_FLOORPLAN)
    add_serve_parser(commands, EXAMPLE_FLOORPLAN)
    add_survey_parser(commands, EXAMPLE_FLOORPLAN)
    add_daemon_parsers(commands)
    add_fleet_parser(commands, EXAMPLE_FLOORPLAN)

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
    if args.command == "stop":
        return run_stop(shutdown=args.daemon)
    if args.command == "status":
        return run_status(args)
    if args.command == "watch":
        return run_watch(args)
    # Every other command reads files (plans, buildings, routes, recordings): within the
    # settings' [limits], whichever command it is (issue 30). A stop, a status and a watch
    # read none, and work whatever the settings file holds.
    from giraff_console import file_limits
    from giraff_console.settings import SettingsError, load_settings

    try:
        settings = load_settings(getattr(args, "config", None))
    except SettingsError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    file_limits.use(settings.limits)
    if args.command == "sim":
        return run_sim(args)
    if args.command == "send":
        return run_send(args)
    if args.command == "export":
        return run_export(args)
    if args.command == "plan":
        return run_plan(args)
    if args.command == "patrols":
        return run_patrols(args)
    if args.command == "floorplan":
        return run_floorplan(args)
    if args.command == "fleet":
        return run_fleet(args)
    # The commands that drive the robot, on the settings file's rates and limits: the
    # console with no command (or replay), the only one that loads Textual.
    command = DRIVING[args.command] if args.command in DRIVING else load_console()
    return command(args, settings, EXAMPLE_FLOORPLAN)


def load_console() -> Callable[[argparse.Namespace, Settings, Path], int]:
    """The console, loaded: most of the package, numpy, OpenCV and Textual.

    All of it lives as long as the console runs. Python's collector walked it again and
    again as it loaded, as the robot was built and as the first screen was drawn: 0.08 s
    of that screen's 0.66 s of CPU (issue 26, item 6). So the collector waits until it
    is loaded, then leaves it out of its rounds for good (gc.freeze); what the console
    makes from then on is collected as before. Only the console (and `serve` once its
    robot is up): a program that calls main() again and again (the tests) would keep
    whatever it had left to collect."""
    gc.disable()
    try:
        from giraff_console.cli.console import run_console
    finally:
        gc.freeze()
        gc.enable()
    return run_console
