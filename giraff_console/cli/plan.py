"""`giraff-console plan FROM TO`: the route between two rooms of a floor plan."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

# Only what the parser needs is imported here: every command, `--version` and `--help`
# included, pays for these before it reads its arguments. What a command needs to run
# (numpy, OpenCV, scipy, the planner, the robot, Textual) is imported by the command,
# when it runs (issue 26, item 6; tests/test_cli.py keeps it so).
from giraff_console.cli.exit_codes import EXIT_USAGE
from giraff_console.data_folders import example_floorplan
from giraff_console.planning.defaults import ROBOT_RADIUS_M

if TYPE_CHECKING:
    pass


# No route between two rooms that exist.
EXIT_NO_ROUTE = 1


def add_plan_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    plan = commands.add_parser(
        "plan",
        help="plan a route between two rooms of a floor plan",
        description="Plan the shortest route from room FROM to room TO: the doors to pass "
        "from A* over the floor plan's room graph (§2.6.2), the way across each room from "
        "D* Lite on its grid (§2.6.4), for a robot of 0.3 m radius. Prints the rooms and "
        "doors passed, the length and the polyline. Exits 2 for an unknown room or a bad "
        "floor plan, 1 when there is no route.",
    )
    plan.add_argument(
        # SUPPRESS: given here or before the command (`giraff-console --floorplan F plan`).
        "--floorplan", type=Path, default=argparse.SUPPRESS, metavar="FILE",
        help=f"floor plan YAML (default: the example care home, {example}); "
        "floorplans/README.md has the format",
    )  # fmt: skip
    plan.add_argument("--json", action="store_true", help="print the route as JSON")
    plan.add_argument(
        "--robot-radius", type=float, default=ROBOT_RADIUS_M, metavar="M",
        help="metres the walls are grown by for planning (default: %(default)s)",
    )  # fmt: skip
    plan.add_argument("origin", metavar="FROM", help="room id to start from, e.g. dock")
    plan.add_argument("destination", metavar="TO", help="room id to go to, e.g. day-room")


def run_plan(args: argparse.Namespace) -> int:
    """The route between two rooms, as text or JSON."""
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.planning.room_graph import PlanningError, UnknownRoomError
    from giraff_console.planning.route_planner import RoutePlanner, walls_of

    try:
        plan = load_floorplan(args.floorplan or example_floorplan())
        planner = RoutePlanner(plan, walls_of(plan), args.robot_radius)
        planned = planner.between_rooms(args.origin, args.destination)
    except (FloorPlanError, OSError, UnknownRoomError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_USAGE
    except PlanningError as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return EXIT_NO_ROUTE
    if args.json:
        print(json.dumps(planned.as_json()))
    else:
        print(f"{' → '.join(planned.route.rooms)}: {planned.length_m:.2f} m")
        print(f"doors: {', '.join(planned.route.doors) or 'none'}")
    return 0
