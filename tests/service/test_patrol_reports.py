"""The service reports a patrol it runs: each stop as it ends, then the run, as events
that cross the daemon's socket unchanged (issue 26). The patrol command prints them, in
its own process and through the daemon alike (tests/service/test_daemon.py)."""

from __future__ import annotations

import json
from pathlib import Path

import giraff_console.service.daemon  # noqa: F401  (registers what crosses the socket)
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol_log import list_runs
from giraff_console.missions.patrol_report import PATROL_JSON_KEYS, STOP_JSON_KEYS
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.mission import Outcome
from giraff_console.service import commands as c
from giraff_console.service.events import PatrolReported, PatrolStopReported, ServiceEvent
from giraff_console.service.robot_service import HERE, RobotService
from giraff_console.service.wire import decode, encode
from tests.missions.site import PLAN, Site

# Virtual seconds a short patrol in the care home may take.
PATROL_LIMIT_S = 300.0


class Patrolling:
    """The care home's simulated robot behind a service with a route book, and all it
    says."""

    def __init__(self, folder: Path, stops: str) -> None:
        navigator = Navigator(PLAN, walls_of(PLAN))
        self.site = Site(navigator)
        control = self.site.control
        routes = folder / "routes"
        routes.mkdir()
        (routes / "two.patrol.yaml").write_text(f"rounds: 1\nstops:\n{stops}")
        self.runs = folder / "runs"
        sessions = Sessions(control, None, folder / "recordings", RecordingSetup(port="sim"),
                            control.note)  # fmt: skip
        drives = DriveSetup.on_loop(control, navigator, sense=self.site.sense)
        book = RouteBook(control, sessions, routes, control.note, drives, runs=self.runs)
        self.service = RobotService(control, drives, building=self.site.site, routes=book,
                                    sessions=sessions)  # fmt: skip
        self.heard: list[ServiceEvent] = []
        self.service.subscribe(self.heard.append)

    def until_reported(self) -> None:
        """Tick until the patrol's report comes, PATROL_LIMIT_S of virtual time at most."""
        limit = self.site.clock.now() + PATROL_LIMIT_S
        while not self.reports(PatrolReported) and self.site.clock.now() < limit:
            self.site.run(1.0, until_ended=False)

    def reports(self, kind: type) -> list:
        return [event for event in self.heard if isinstance(event, kind)]


def crosses(event: ServiceEvent) -> bool:
    """Whether `event` comes back equal from the daemon's socket."""
    return decode(json.loads(json.dumps(encode(event)))) == event


def test_each_stop_is_reported_as_it_ends_and_the_patrol_after_its_end(tmp_path):
    robot = Patrolling(tmp_path, "  - {room: nurse-station}\n  - {room: dock}\n")
    assert robot.service.execute(c.RunPatrol("two")).ok
    robot.until_reported()
    stops = [event.report for event in robot.reports(PatrolStopReported)]
    [patrol] = [event.report for event in robot.reports(PatrolReported)]
    assert [(s.patrol, s.round, s.stop, s.room, s.end.outcome) for s in stops] == [
        ("two", 1, 1, "nurse-station", Outcome.ARRIVED_UNVERIFIED),
        ("two", 1, 2, "dock", Outcome.ARRIVED_UNVERIFIED),
    ]  # fmt: skip
    assert all(list(s.as_json()) == list(STOP_JSON_KEYS) for s in stops)
    # Measured as `go` measures: from the simulator's true pose, to the room's point.
    assert all(s.pose_true is not None and s.as_json()["error_m"] < 0.05 for s in stops)
    assert list(patrol.as_json()) == list(PATROL_JSON_KEYS)
    assert (patrol.patrol, patrol.stops, patrol.failed, patrol.end.outcome) == (
        "two", 2, 0, Outcome.ARRIVED_UNVERIFIED)  # fmt: skip
    # The patrol's report after its end and its stops': a front end that has it has all.
    ended = next(i for i, event in enumerate(robot.heard)
                 if isinstance(event, MissionChanged) and event.end is not None)  # fmt: skip
    last_stop = max(i for i, event in enumerate(robot.heard)
                    if isinstance(event, PatrolStopReported))  # fmt: skip
    assert robot.heard.index(robot.reports(PatrolReported)[0]) > max(ended, last_stop)
    assert all(crosses(event) for event in robot.reports(PatrolStopReported | PatrolReported))
    [run] = list_runs(robot.runs)
    assert (run.patrol, run.by, run.stops) == ("two", HERE, 2)


def test_a_scheduled_patrol_stopped_on_its_way_reports_the_stop_it_never_reached(tmp_path):
    robot = Patrolling(tmp_path, "  - {room: kitchen}\n  - {room: dock}\n")
    assert robot.service.run_scheduled("two").ok
    robot.site.run(2.0, until_ended=False)
    assert robot.service.execute(c.StopMission()).ok
    robot.until_reported()
    [stop] = [event.report for event in robot.reports(PatrolStopReported)]
    [patrol] = [event.report for event in robot.reports(PatrolReported)]
    assert (stop.stop, stop.room, stop.end.outcome) == (1, "kitchen", Outcome.STOPPED_BY_OPERATOR)
    assert not stop.end.outcome.arrived and stop.as_json()["error_m"] > 1.0
    assert (patrol.end.outcome, patrol.stops, patrol.arrived, patrol.failed) == (
        Outcome.STOPPED_BY_OPERATOR, 2, 0, 1)  # fmt: skip
    assert all(crosses(event) for event in robot.reports(PatrolStopReported | PatrolReported))
