"""The daemon's scheduled patrols: started when due, skipped while one runs, logged."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol_log import list_runs
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.schedule import ScheduledPatrol
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.session import RecordingSetup
from giraff_console.robot.deadman import Intent
from giraff_console.service import commands as c
from giraff_console.service.patrol_schedule import PatrolSchedule
from giraff_console.service.robot_service import RobotService
from tests.missions.site import PLAN, Site

PATROL = """\
rounds: 1
snapshots: false
stops:
  - {room: room-101}
"""
EVERY_HOUR = ScheduledPatrol("rounds", 3600.0, dt.time(22, 0), dt.time(6, 0))


class Night:
    """The care home's robot in the daemon's service, its schedule on a clock we set."""

    def __init__(self, folder: Path) -> None:
        navigator = Navigator(PLAN, walls_of(PLAN))
        self.site = Site(navigator)
        control = self.site.control
        routes = folder / "routes"
        routes.mkdir()
        (routes / "rounds.patrol.yaml").write_text(PATROL)
        self.runs = folder / "runs"
        sessions = Sessions(control, None, folder / "recordings", RecordingSetup(port="sim"),
                            print)  # fmt: skip
        drives = DriveSetup.on_loop(control, navigator, sense=self.site.sense)
        book = RouteBook(control, sessions, routes, print, drives, runs=self.runs)
        self.service = RobotService(control, drives, routes=book, sessions=sessions)
        self.now = dt.datetime(2026, 11, 24, 21, 30)
        self.schedule = PatrolSchedule(self.service, (EVERY_HOUR,), self.runs, lambda: self.now)

    def at(self, hour: int, minute: int = 0, day: int = 24) -> None:
        """Move the wall clock on and let the schedule look."""
        self.now = dt.datetime(2026, 11, day, hour, minute)
        self.schedule.look()
        self.site.run(0.2, until_ended=False)  # the loop takes the mission up


def test_a_due_patrol_starts_and_its_run_is_logged(tmp_path):
    night = Night(tmp_path)
    night.at(21, 59)
    assert night.site.control.mission is None  # not yet due
    night.at(22, 0)
    mission = night.site.control.mission
    assert mission is not None and mission.name == "rounds"
    night.site.run(300.0, until_ended=False)
    assert night.site.control.mission is None
    [run] = list_runs(night.runs)
    assert (run.patrol, run.by, run.scheduled, run.state, run.why) == (
        "rounds",
        "schedule",
        True,
        "ended",
        "done",
    )
    assert run.stops == 1


def test_a_slot_that_comes_while_its_patrol_runs_is_skipped_with_why(tmp_path):
    night = Night(tmp_path)
    night.at(22, 0)
    night.site.control.pause_mission(True)  # still running an hour later
    night.site.run(0.2, until_ended=False)
    night.at(23, 0)
    runs = list_runs(night.runs)
    skipped = [run for run in runs if run.state == "skipped"]
    assert len(skipped) == 1
    assert "has not finished" in (skipped[0].why or "")
    assert night.site.control.mission is not None  # the first run carries on


def test_a_slot_is_skipped_while_the_operator_drives(tmp_path):
    night = Night(tmp_path)
    night.site.run(0.2, until_ended=False)
    night.service.execute(c.Press(Intent.FORWARD))
    night.site.run(0.1, until_ended=False)
    night.at(22, 0)
    assert night.site.control.mission is None
    [run] = list_runs(night.runs)
    assert run.state == "skipped" and "driven by the keys" in (run.why or "")


def test_a_first_stop_that_cannot_be_planned_is_logged_and_the_run_is_not_arrived(tmp_path):
    night = Night(tmp_path)
    (tmp_path / "routes" / "rounds.patrol.yaml").write_text(
        "rounds: 1\nsnapshots: false\nstops:\n  - {room: no-such-room}\n  - {room: room-101}\n"
    )
    night.at(22, 0)
    night.site.run(300.0, until_ended=False)
    assert night.site.control.mission is None
    [run] = list_runs(night.runs)
    lines = [json.loads(line) for line in Path(run.file).read_text().splitlines()]
    stops = [line for line in lines if line["event"] == "stop"]
    assert [stop["place"] for stop in stops] == ["no-such-room", "room-101"]
    assert stops[0]["outcome"] != "arrived" and "no-such-room" in stops[0]["detail"]
    assert run.state == "ended" and run.arrived is False
