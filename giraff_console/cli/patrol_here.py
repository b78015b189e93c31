"""A patrol on the robot in this process, for `giraff-console patrol` (cli/patrol.py):
each stop said as the robot comes to rest there, or as the patrol ends on its way, and
the patrol's last line. Apart from the parser, so that `--help` does not load the
missions it runs (issue 26, item 6).
"""

from __future__ import annotations

import json
import math
import queue
from dataclasses import replace

from giraff_console.cli.drive import run_mission
from giraff_console.cli.exit_codes import EXIT_FAILED, EXIT_USAGE, exit_code
from giraff_console.cli.report import fail
from giraff_console.link.motor_state import MotorState
from giraff_console.missions.go_to import GoReport
from giraff_console.missions.names import DOCK
from giraff_console.missions.patrol import Patrol, PatrolError, PatrolRun, Stop, StopReached
from giraff_console.missions.route import Route
from giraff_console.missions.route_book import RunLog
from giraff_console.protocol.codec import Command
from giraff_console.robot.mission import MissionEnd
from giraff_console.runtime.robot import Robot


def patrol_here(robot: Robot, patrol: Patrol, routes: dict[str, Route], as_json: bool) -> int:
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
    # Logged where `giraff-console patrols` lists it, as the console's and the daemon's
    # runs are (issue 26).
    log.runs.start(patrol.name, scheduled=False, by="the patrol command")
    if not run_mission(robot, run, log.ended, lambda: log.print_lines(as_json)):
        return fail("no answer from the board", EXIT_FAILED)
    summary = log.summary()
    if as_json:
        print(json.dumps(summary), flush=True)
    else:
        print(f"patrol {patrol.name}: {summary['why']}; {summary['arrived']} of "
              f"{summary['stops']} stops arrived, in {summary['duration_s']:.0f} s")  # fmt: skip
    return exit_code(log.end) if log.end is not None else EXIT_FAILED


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
        self.runs = RunLog(robot.routes.runs, robot.control.note, None)
        self.run: _TimedPatrol | None = None
        self.records: list[dict] = []
        # The stops that did not get there (their outcome not an arrival).
        self.failed = 0
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
        self.runs.reached(stop, self.robot.control.estimate().pose)
        dwell = self.patrol.stops[stop.stop_index - 1].dwell if stop.reached else 0.0
        self._leg_from = self.robot.control.clock.now() + dwell

    def ended(self, end: MissionEnd) -> None:
        self.end, self.why = end, end.why
        self.runs.end(end, self.runs.reached_count)
        self.ended_at = self.robot.control.clock.now()
        count = len(self.patrol.stops)
        leg = len(self.records)
        if leg < self.patrol.rounds * count:
            # Ended on the way to the next stop: it did not arrive there.
            self._record(leg // count + 1, leg % count + 1, replace(end, detail=end.why))

    def _record(self, round_number: int, index: int, end: MissionEnd,
                max_jerk: float | None = None) -> None:  # fmt: skip
        control, now = self.robot.control, self.robot.control.clock.now()
        self.failed += not end.outcome.arrived
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
            "failed": self.failed,
            # How it ended, with the keys a patrol asked of the daemon prints too.
            "outcome": self.end.outcome.value if self.end is not None else None,
            "why": self.why,
            "detail": self.end.detail if self.end is not None else "",
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
