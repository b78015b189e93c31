"""`giraff-console go ROOM`: take the robot to a room without the console's screen.

`go dock` drives onto the dock, square on (missions/docking.py).

The same mission the console's `go` runs (missions/go_to.py), on the same control loop:
from the shell, a script or a test. Progress (a bar, the distance left and an ETA) goes
to standard error; `--json` prints how it went on standard output. The exit code says
whether the robot arrived: 0 yes, 3 there but not confirmed by a marker (arrived
unverified), 1 no (stall, ESTOP, lost link, no way, lost, interrupted), 2 a mistake in
the command (an unknown room, a bad floor plan or settings).

The set-up it shares with `patrol` (the plan, the simulator, the control loop, the
markers and the camera that sees them, the virtual clock) is headless.py's.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from giraff_console.headless import (
    EXIT_ARRIVED,
    EXIT_FAILED,
    EXIT_UNVERIFIED,
    EXIT_USAGE,
    HeadlessRobot,
    UsageError,
    add_robot_options,
    fail,
)
from giraff_console.missions.docking import DOCK
from giraff_console.planning.room_graph import PlanningError, UnknownRoomError
from giraff_console.settings import Settings


def add_go_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    go = commands.add_parser(
        "go",
        help="take the robot to a room of the floor plan, without the screen",
        description="Plan a route from the floor plan's start room (where the robot is "
        "taken to stand) to ROOM and drive it: clothoid turns, a jerk-limited speed "
        "profile, steering from the pose estimate (the odometry corrected by the plan's "
        "markers), replanning round what the range finder sees. Progress goes to "
        "standard error. Exits 0 when the robot arrived with its pose confirmed by a "
        "marker, 3 when it arrived by an estimate nothing confirmed (dead reckoning, or no "
        "marker in sight at the goal), 1 when it did not arrive (the reason is printed), 2 "
        "for an unknown room or a bad floor plan.",
    )
    go.add_argument(
        "room", metavar="ROOM",
        help=f"room id, e.g. kitchen; {DOCK} drives onto the dock (the start room's point, "
        "facing its heading) the last metres straight",
    )  # fmt: skip
    add_robot_options(go, example)


def run_go(args: argparse.Namespace, settings: Settings, port: str | None,
           example: Path) -> int:  # fmt: skip
    """Drive to `args.room`; the exit code says how it went."""
    try:
        robot = HeadlessRobot(args, settings, port, example)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    plan = robot.plan
    if args.room not in plan.rooms and args.room != DOCK:
        return fail(plan.no_room(args.room, also=[DOCK]), EXIT_USAGE)
    try:
        # Planned before the loop starts, so that the simulator's clock has not moved
        # on by however long planning took.
        mission = robot.drives.go(args.room)
    except PlanningError as error:
        return fail(str(error), EXIT_USAGE if isinstance(error, UnknownRoomError) else EXIT_FAILED)
    # The report and the true pose are taken on the loop's thread as the mission ends,
    # at a virtual time that does not depend on how fast the clock runs.
    ended: list = []
    if not robot.run(mission, lambda why: ended.append((mission.report(why), robot.true_pose()))):
        return fail("no answer from the board", EXIT_FAILED)
    report, pose_true = ended[0]
    data = report.as_json(pose_true)
    if args.json:
        print(json.dumps(data))
    else:
        goal = "the dock" if args.room == DOCK else "the room's point"
        print(f"{mission.name}: {report.end.words}; {data['error_m'] * 100:.1f} cm and "
              f"{data['heading_error_deg']:.1f}° from {goal}, in "
              f"{data['duration_s']:.1f} s (jerk-limited optimum "
              f"{data['time_optimal_s']:.1f} s), {len(data['stops'])} stops")  # fmt: skip
    if report.arrived:
        return EXIT_ARRIVED
    return EXIT_UNVERIFIED if report.end.outcome.arrived else EXIT_FAILED
