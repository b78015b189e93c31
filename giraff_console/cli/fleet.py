"""`giraff-console fleet`: the fleet view, a master control's screen on every robot on a
VDA 5050 broker (issue 28, item 3; docs/fleet.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. The master, paho, the schemas
# and Textual are imported when the command runs (issue 26, item 6).
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.cli.report import fail
from giraff_console.data_folders import example_floorplan


def add_fleet_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    fleet = commands.add_parser(
        "fleet",
        help="watch and direct every robot on a VDA 5050 broker",
        description="The fleet view: a row for every robot on the broker (its connection, "
        "operating mode, battery, mission and last error, live) and the selected one on "
        "its map. g sends it to a room (a VDA 5050 order from the room it is in), p "
        "pauses, r resumes, c cancels its order, d sends it to the dock to charge (instant "
        "actions); q leaves, and the robots carry on. It is a master control like any "
        "other: a third-party fleet manager can take its place. The broker and the rest "
        "default to the settings file's [fleet] table. Exits 2 for a bad broker URL, "
        "certificate, credentials file or floor plan.",
    )
    fleet.add_argument(
        "--broker", metavar="URL",
        help="mqtt://HOST[:PORT] or mqtts://HOST[:PORT] (TLS) (default: fleet.broker)",
    )  # fmt: skip
    fleet.add_argument("--ca-file", type=Path, metavar="FILE",
                       help="the CA of the broker's certificate (default: fleet.ca_file, "
                       "else the system's)")  # fmt: skip
    fleet.add_argument("--credentials", type=Path, metavar="FILE",
                       help="one line user:password, owner-only "
                       "(default: fleet.credentials)")  # fmt: skip
    fleet.add_argument("--interface", metavar="NAME",
                       help="the first level of the robots' topics (default: fleet.interface, "
                       "uagv)")  # fmt: skip
    fleet.add_argument(
        # SUPPRESS: given here or before the command (`giraff-console --floorplan F fleet`).
        "--floorplan", type=Path, default=argparse.SUPPRESS, metavar="FILE",
        help=f"the floor plan to draw the robots on that say they are on it (their mapId "
        f"is its name; default: the example care home, {example})",
    )  # fmt: skip


def run_fleet(args: argparse.Namespace) -> int:
    """The fleet view until the operator leaves it."""
    from giraff_console.fleet.broker_link import Broker, BrokerError
    from giraff_console.fleet.master import FleetMaster
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.route_planner import walls_of
    from giraff_console.settings import SettingsError, load_settings
    from giraff_console.tui.fleet.app import FleetView
    from giraff_console.tui.map_scene import plan_scene

    try:
        settings = load_settings(args.config).fleet
    except SettingsError as error:
        return fail(str(error), EXIT_USAGE)
    url = args.broker or settings.broker
    if not url:
        return fail("no broker: give --broker URL, or broker in the settings' [fleet] table",
                    EXIT_USAGE)  # fmt: skip
    ca_file = args.ca_file or (Path(settings.ca_file) if settings.ca_file else None)
    credentials = args.credentials or (
        Path(settings.credentials) if settings.credentials else None
    )  # fmt: skip
    try:
        broker = Broker.parse(url, ca_file=ca_file, credentials=credentials)
        master = FleetMaster(broker, interface=args.interface or settings.interface)
    except (BrokerError, ValueError) as error:  # ValueError: an interface no topic can have
        return fail(str(error), EXIT_USAGE)
    try:
        plan = load_floorplan(args.floorplan or example_floorplan())
        walls = walls_of(plan)
    except (FloorPlanError, OSError) as error:
        return fail(str(error), EXIT_USAGE)
    app = FleetView(master, plan=plan, scene=plan_scene(plan, walls) if walls else None)
    master.start()
    try:
        app.run()
    finally:
        master.stop()
    return app.return_code or 0
