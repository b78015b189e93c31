"""`giraff-console survey`: the robot maps the markers on the walls and writes them into
the floor plan, without the console's screen (issue 25, item 2; missions/survey.py).

The robot starts on its dock (the plan's start room: the simulator's robot is put
there, a real robot's operator says so with `--at dock`), drives to every room (or
`--rooms`), nearest first, looks round in each, tries a room it could not reach once
more, and comes back to the dock. Then the
markers are estimated with the robot's path (a few seconds) and written into the plan,
each with its uncertainty; `--dry-run` only prints them. Progress goes to standard
error; `--json` prints the markers found as JSON. The plan's `landmarks:` key gives
the markers' family and size (its markers, if any, are surveyed afresh); a plan without
one takes `--family` and `--size`.

For trying it in the simulator: `--sim-markers FILE` hangs FILE's markers in the
simulated building instead of the plan's, so that a plan with no markers can be
surveyed against a building that has them.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

# Light modules only: the parser is built with every command's (cli/main.py). What
# the survey drives and maps with is imported when it runs (issue 26, item 6).
from giraff_console.camera.marker_reach import STANDARD_SIZE_M
from giraff_console.cli.exit_codes import EXIT_ARRIVED, EXIT_FAILED, EXIT_USAGE
from giraff_console.cli.options import add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.planning.defaults import DEFAULT_FAMILY
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.service.runtime_folder import socket_path

if TYPE_CHECKING:
    from giraff_console.missions.survey import Surveyed
    from giraff_console.planning.floorplan import Landmarks
    from giraff_console.runtime.robot import Robot
    from giraff_console.settings import Settings


def add_survey_parser(commands: argparse._SubParsersAction, example: Path) -> None:
    survey = commands.add_parser(
        "survey",
        help="map the markers on the walls and write them into the floor plan",
        description="From the dock, drive to every room of the floor plan (or --rooms), "
        "look round in each, try a room it could not reach once more, and come back; "
        "meanwhile find every marker the camera sees, "
        "then estimate each one's place with the robot's path and write them, with how "
        "well each is known, into the plan's landmarks (floorplans/README.md). The "
        "robot starts on its dock: on a real robot say so with --at dock. Exits 0 when "
        "every room was reached and the plan written, 1 when rooms were left out or "
        "nothing was found (the plan is written with what was), 2 for a mistake in the "
        "command.",
    )
    survey.add_argument(
        "--rooms", metavar="A,B,...",
        help="the rooms to visit (default: every room of the plan)",
    )  # fmt: skip
    survey.add_argument("--dry-run", action="store_true",
                        help="print the markers found; do not write the plan")  # fmt: skip
    survey.add_argument(
        "--family", default=DEFAULT_FAMILY,
        help="the markers' family, for a plan without landmarks (default: %(default)s)",
    )  # fmt: skip
    survey.add_argument(
        "--size", type=float, default=STANDARD_SIZE_M, metavar="M",
        help="the markers' printed side in metres, for a plan without landmarks "
        "(default: %(default)s)",
    )  # fmt: skip
    add_robot_options(survey, example)


def run_survey(args: argparse.Namespace, settings: Settings, example: Path) -> int:
    """Survey, then write or print the markers; the exit code says how it went."""
    from giraff_console.cli.drive import print_note
    from giraff_console.runtime.options import UsageError
    from giraff_console.runtime.robot import Robot
    from giraff_console.service.daemon import daemon_alive

    try:
        options = robot_options(args, settings, surveying=_surveying(args))
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    if options.port is not None and daemon_alive(socket_path()):
        return fail(f"the daemon at {socket_path()} has the robot: stop it first "
                    "(giraff-console stop --daemon), then survey", EXIT_USAGE)  # fmt: skip
    try:
        robot = Robot(options, settings, example, notes=print_note)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    with robot:
        return _survey(robot, args, settings)


def _survey(robot: Robot, args: argparse.Namespace, settings: Settings) -> int:
    from giraff_console.cli.drive import run_mission
    from giraff_console.missions.survey import (
        Tour,
        plan_walls,
        redraw_map,
        surveyed,
        tour,
        write_surveyed,
    )
    from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
    from giraff_console.robot.localisation import PoseBasis, start_covariance
    from giraff_console.robot.survey_log import SurveyLog

    try:
        # The plan as its file has it: the markers a survey of some rooms keeps, and
        # their heights, which the camera cannot measure well.
        given = load_floorplan(robot.plan.path)
    except FloorPlanError as error:
        return fail(str(error), EXIT_USAGE)
    plan = robot.plan
    assert plan.landmarks is not None  # the robot was given the markers to look for
    if plan.start is None:
        return fail(f"{plan.path}: a survey starts on the dock: the plan names no start room",
                    EXIT_USAGE)  # fmt: skip
    rooms = [room.strip() for room in args.rooms.split(",")] if args.rooms else None
    unknown = sorted(set(rooms or []) - set(plan.rooms))
    if unknown:
        return fail(f"--rooms: {'; '.join(map(plan.no_room, unknown))}", EXIT_USAGE)
    if robot.eye is None and robot.camera is None:
        return fail("a survey needs a camera that can place markers: --camera and "
                    "--calibration on a real robot", EXIT_USAGE)  # fmt: skip
    control = robot.control
    if control.estimate().basis is PoseBasis.ASSUMED:
        # Every marker is placed from where the robot is believed to be: a pose only
        # read back from before a restart would put them all wrong.
        return fail(f"a survey maps the markers from where the robot stands: put it on "
                    f"its dock and say so with --at {plan.start}", EXIT_USAGE)  # fmt: skip
    start = robot.control.estimate().pose
    log = SurveyLog(start, control.odometry.wheel_base, start_cov=start_covariance())
    walls = plan_walls(plan)
    control.localisation.start_survey(log, [(wall.a, wall.b) for wall in walls])
    limits = settings.motion.limits()
    # Each room's look round ends with the map redrawn from the survey so far
    # (missions/survey.py's redraw_map), and the way on planned from there.
    mission = Tour(tour(plan, rooms), robot.drives.go, lambda: control.pose, limits,
                   control.period, control.note,
                   looked_round=lambda: redraw_map(control.localisation, walls))  # fmt: skip
    ended: list[MissionEnd] = []
    if not run_mission(robot, mission, ended.append):
        return fail("no answer from the board", EXIT_FAILED)
    control.localisation.end_survey()
    found = surveyed(given, log, plan.landmarks.family, plan.landmarks.size)
    left_out = mission.not_reached
    done = bool(ended) and ended[0].outcome is Outcome.DONE
    written = None
    # A survey stopped part-way (Ctrl-C, the board gone) writes nothing: the markers it
    # had seen are printed, and the plan stays as it was.
    if not args.dry_run and done and found.landmarks.markers:
        try:
            written = write_surveyed(given, found, whole=rooms is None and not left_out).path
        except (FloorPlanError, OSError, ValueError) as error:
            return fail(f"the markers were found but not written: {error}", EXIT_FAILED)
    report = _report(found, ended[0].why if ended else "not run", left_out, written)
    print(json.dumps(report) if args.json else _words(report))
    complete = done and not left_out and found.landmarks.markers
    return EXIT_ARRIVED if complete else EXIT_FAILED


def _surveying(args: argparse.Namespace) -> Landmarks:
    """The markers to look for, for a plan that has no `landmarks:` key: the options'
    family and size (the robot takes the plan's own where it has them)."""
    from giraff_console.planning.floorplan import Landmarks
    from giraff_console.runtime.options import UsageError

    if not (args.size > 0 and math.isfinite(args.size)):
        raise UsageError("--size must be a positive number of metres")
    return Landmarks(args.family, args.size, ())


def _report(found: Surveyed, why: str, left_out: list[str], written: Path | None) -> dict:
    markers = [
        {"id": m.id, "at": list(m.at), "facing": m.facing,
         "sigma_m": m.sigma[0] if m.sigma else None, "sigma_deg": m.sigma[1] if m.sigma else None}
        for m in found.landmarks.markers
    ]  # fmt: skip
    return {
        "why": why,
        "markers": markers,
        "left_out": {str(marker_id): why for marker_id, why in found.left_out.items()},
        "outliers": found.outliers,
        "rooms_left_out": left_out,
        "written": str(written) if written is not None else None,
    }


def _words(report: dict) -> str:
    lines = [f"survey {report['why']}: {len(report['markers'])} markers found"]
    for marker in report["markers"]:
        lines.append(f"  marker {marker['id']} at ({marker['at'][0]:.3f}, {marker['at'][1]:.3f}) "
                     f"facing {marker['facing']:.1f}°, ±{marker['sigma_m'] * 100:.1f} cm and "
                     f"±{marker['sigma_deg']:.1f}°")  # fmt: skip
    for marker_id, why in report["left_out"].items():
        lines.append(f"  marker {marker_id} left out: {why}")
    if report["rooms_left_out"]:
        lines.append(f"rooms not reached: {', '.join(report['rooms_left_out'])}")
    lines.append(f"written into {report['written']}" if report["written"] else "not written")
    return "\n".join(lines)
