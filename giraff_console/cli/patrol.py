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
patrol. The exit codes are `go`'s (cli/drive.py): the patrol judges its own end, every
stop reached (confirmed or not) or a stop missed (missions/patrol.py).
"""

from __future__ import annotations

import argparse
import json
import math
import queue
from dataclasses import replace
from pathlib import Path

from giraff_console.cli.daemon import attach_if_running
from giraff_console.cli.drive import (
    EXIT_FAILED,
    EXIT_HELP,
    EXIT_USAGE,
    drive_there,
    exit_code,
    print_note,
    run_mission,
)
from giraff_console.cli.options import add_folder_options, add_robot_options, robot_options
from giraff_console.cli.report import fail
from giraff_console.data_folders import data_folder, default_routes, example_routes
from giraff_console.link.motor_state import MotorState
from giraff_console.missions.docking import DOCK
from giraff_console.missions.go_to import GoReport
from giraff_console.missions.patrol import (
    PATROL_SUFFIX,
    Patrol,
    PatrolError,
    PatrolRun,
    Stop,
    StopReached,
    list_patrols,
    load_patrol,
    patrol_file,
)
from giraff_console.missions.route import Route, RouteError, load_route
from giraff_console.protocol.codec import Command
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.runtime.options import UsageError
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service.events import Reply
from giraff_console.service.remote import RemoteRobot
from giraff_console.settings import Settings

# The stops that got there, confirmed or not, as their `outcome` is printed.
ARRIVED_VALUES = frozenset(outcome.value for outcome in Outcome if outcome.arrived)


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
    attached = attach_if_running(args, "patrol")
    if isinstance(attached, int):
        return attached
    if attached is not None:
        return _on_the_daemon(attached, c.RunPatrol(args.name), args.json)
    try:
        patrol, routes = _load(args.name, data_folder(args.routes, settings.routes,
                                                      default_routes()))  # fmt: skip
        robot = Robot(robot_options(args, settings), settings, example, notes=print_note)
    except UsageError as error:
        return fail(str(error), EXIT_USAGE)
    with robot:
        return _patrol_here(robot, patrol, routes, args.json)


def _patrol_here(robot: Robot, patrol: Patrol, routes: dict[str, Route], as_json: bool) -> int:
    """The patrol on the robot in this process, each stop said as it ends."""
    rooms = robot.plan.rooms
    known = {DOCK} if robot.plan.start is not None else set()  # the dock is the start room's
    unknown = sorted({s.room for s in patrol.stops if s.room and s.room not in rooms} - known)
    if unknown:
        wrong = "; ".join(robot.plan.no_room(room, also=known) for room in unknown)
        return fail(f"patrol {patrol.name}: {wrong}", EXIT_USAGE)
    log = StopLog(robot, patrol, routes)
    try:
        # The first leg is planned here, before the loop starts (as `go` plans).
        run = _TimedPatrol(patrol, routes, log.reached, go=robot.drives.go,
                           follow=robot.drives.follow, notify=robot.control.note,
                           estimate=robot.control.estimate)  # fmt: skip
    except PatrolError as error:
        return fail(str(error), EXIT_USAGE)
    log.run = run
    if not run_mission(robot, run, log.ended, lambda: log.print_lines(as_json)):
        return fail("no answer from the board", EXIT_FAILED)
    summary = log.summary()
    if as_json:
        print(json.dumps(summary), flush=True)
    else:
        print(f"patrol {patrol.name}: {summary['why']}; {summary['arrived']} of "
              f"{summary['stops']} stops arrived, in {summary['duration_s']:.0f} s")  # fmt: skip
    return exit_code(log.end) if log.end is not None else EXIT_FAILED


def _on_the_daemon(remote: RemoteRobot, request: c.RunPatrol, as_json: bool) -> int:
    """The patrol run by the daemon (logged where `patrols` lists it): how it ended."""
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


class _TimedPatrol(PatrolRun):
    """A patrol run that notes when it first drives, for the times in its report."""

    started_at: float | None = None

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self.started_at is None:
            self.started_at = now
        return super().step(now, state)


class StopLog:
    """How each stop went, taken on the loop's thread as the robot comes to rest there
    (or as the patrol ends on its way), and printed from the main thread."""

    def __init__(self, robot: Robot, patrol: Patrol, routes: dict[str, Route]) -> None:
        self.robot = robot
        self.patrol = patrol
        self.routes = routes
        self.run: _TimedPatrol | None = None
        self.records: list[dict] = []
        self.why = "not started"
        self.end: MissionEnd | None = None
        self.ended_at: float | None = None
        self._lines: queue.SimpleQueue[dict] = queue.SimpleQueue()
        # When the leg under way started: the end of the last stop's dwell (None: the
        # patrol's start).
        self._leg_from: float | None = None

    # On the loop's thread.

    def reached(self, stop: StopReached) -> None:
        """A stop's leg ended: arrived (confirmed or not), or failed and skipped."""
        why = "done" if stop.reached else f"failed: {stop.detail}"
        self._record(stop.round, stop.stop_index, MissionEnd(stop.outcome, why, stop.detail),
                     stop.max_jerk)  # fmt: skip
        dwell = self.patrol.stops[stop.stop_index - 1].dwell if stop.reached else 0.0
        self._leg_from = self.robot.control.clock.now() + dwell

    def ended(self, end: MissionEnd) -> None:
        self.end, self.why = end, end.why
        self.ended_at = self.robot.control.clock.now()
        count = len(self.patrol.stops)
        leg = len(self.records)
        if leg < self.patrol.rounds * count:
            # Ended on the way to the next stop: it did not arrive there.
            self._record(leg // count + 1, leg % count + 1, replace(end, detail=end.why))

    def _record(self, round_number: int, index: int, end: MissionEnd,
                max_jerk: float | None = None) -> None:  # fmt: skip
        control, now = self.robot.control, self.robot.control.clock.now()
        stop = self.patrol.stops[index - 1]
        started = self.run.started_at if self.run is not None else None
        if started is None:
            started = now
        leg_from = started if self._leg_from is None else self._leg_from
        estimate = control.estimate()
        goal = self._goal(stop)
        report = GoReport(
            room=stop.place, end=end,
            pose_estimate=estimate.pose,
            goal=goal[0] if goal else (math.nan, math.nan),
            goal_heading=goal[1] if goal else None,
            duration_s=now - leg_from, time_optimal_s=0.0, pose_true=self.robot.true_pose(),
        )  # fmt: skip
        measured = report.as_json()
        record = {
            "stop": index,
            "round": round_number,
            "room": stop.room,
            "route": stop.route,
            "arrived": report.arrived,
            "outcome": measured["outcome"],
            "why": end.why,
            "detail": end.detail,
            "pose_estimate": measured["pose_estimate"],
            "pose_true": measured["pose_true"],
            "error_m": measured["error_m"] if goal else None,
            "heading_error_deg": measured["heading_error_deg"] if goal else None,
            "sigma_m": round(estimate.sigma_m, 4),
            "sigma_heading_deg": round(math.degrees(estimate.sigma_heading), 3),
            "found": estimate.found,
            "seen": list(estimate.seen),
            "rejected": list(estimate.rejected),
            "since_fix_m": round(estimate.since_fix_m, 3),
            "basis": estimate.basis.value,
            "duration_s": measured["duration_s"],
            "t_s": round(now - started, 3),
            "max_jerk": None if max_jerk is None else round(max_jerk, 3),
        }
        self.records.append(record)
        self._lines.put(record)

    def _goal(self, stop: Stop) -> tuple[tuple[float, float], float | None] | None:
        """Where the stop ends: the room's point and heading (radians; the dock's for
        `dock`), or the end of the route's taught path; None for a route without one."""
        if stop.room is not None:
            start = self.robot.plan.start
            room = self.robot.plan.rooms[start if stop.room == DOCK and start else stop.room]
            return room.at, None if room.heading is None else math.radians(room.heading)
        path = self.routes[str(stop.route)].path
        return ((path[-1].x, path[-1].y), path[-1].heading) if path else None

    # On the main thread.

    def print_lines(self, as_json: bool) -> None:
        """The stops recorded since the last call."""
        while True:
            try:
                record = self._lines.get_nowait()
            except queue.Empty:
                return
            if as_json:
                print(json.dumps(record), flush=True)
            else:
                print(_stop_line(record), flush=True)

    def summary(self) -> dict:
        """The patrol's last line."""
        run = self.run
        started = run.started_at if run is not None else None
        end = self.ended_at
        eye = self.robot.eye
        localisation = self.robot.control.localisation
        return {
            "patrol": self.patrol.name,
            "rounds": self.patrol.rounds,
            "stops": self.patrol.rounds * len(self.patrol.stops),
            "arrived": sum(record["arrived"] for record in self.records),
            "failed": sum(record["outcome"] not in ARRIVED_VALUES for record in self.records),
            "why": self.why,
            "duration_s": round(end - started, 3) if started is not None and end else 0.0,
            "landmarks": self.robot.landmarks,
            "eye": eye.cost() if eye is not None else None,
            # Which markers corrected the pose, and which the gate rejected, over the run,
            # and how many sightings of them it rejected in all.
            "markers_used": sorted(localisation.used),
            "markers_rejected": sorted(localisation.rejections),
            "rejections": sum(localisation.rejections.values()),
        }


def _stop_line(record: dict) -> str:
    place = record["room"] or record["route"]
    how = record["detail"] or record["why"]
    where = ""
    if record["error_m"] is not None:
        where = (f"; {record['error_m'] * 100:.1f} cm and {record['heading_error_deg']:.1f}° "
                 "from its goal")  # fmt: skip
    return (f"round {record['round']}, stop {record['stop']} ({place}): {how}{where}; "
            f"known to {record['sigma_m'] * 100:.1f} cm")  # fmt: skip
