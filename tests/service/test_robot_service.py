"""The robot service in its own process: stops that win, who may move, and the outbox."""

from __future__ import annotations

import math
import shutil
import threading
from dataclasses import replace

from giraff_console.link import Exchange
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.deadman import Intent
from giraff_console.robot.loop_events import Note
from giraff_console.robot.telemetry import Telemetry
from giraff_console.service import commands as c
from giraff_console.service.outbox import Outbox
from giraff_console.service.robot_service import HANDLERS, RobotService
from tests.missions.site import EXAMPLE, PLAN, Site


def service_on_site() -> tuple[RobotService, Site]:
    navigator = Navigator(PLAN, walls_of(PLAN))
    site = Site(navigator)
    return RobotService(site.control, DriveSetup.on_loop(site.control, navigator)), site


def test_a_stop_while_a_route_is_planned_keeps_the_mission_from_starting():
    service, site = service_on_site()
    plan = service.drives.go

    def go_while_the_operator_stops(room: str):
        mission = plan(room)
        service.execute(c.Halt())  # Space, from the screen's thread, mid-planning
        return mission

    service.drives = replace(service.drives)  # a copy, to patch its `go`
    object.__setattr__(service.drives, "go", go_while_the_operator_stops)
    reply = service.execute(c.Go("room-101"))
    assert not reply.ok and "stopped" in reply.text
    site.run(2.0, until_ended=False)
    assert site.control.mission is None
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), PLAN.rooms["dock"].at) < 0.01


def test_stop_mission_ends_one_the_loop_has_not_taken_up_yet():
    service, site = service_on_site()
    assert service.execute(c.Go("room-101")).ok
    assert service.execute(c.StopMission()).ok  # before the next tick starts it
    site.run(2.0, until_ended=False)
    assert site.control.mission is None
    assert service.situation().last_mission is not None


def test_a_stop_asked_thousands_of_times_is_one_stop_for_the_loop():
    """A console asking again and again (issue 30: 2,000 Halts in one write froze the
    loop for 30 s, a board exchange each) costs the loop's tick one stop."""
    service, site = service_on_site()
    assert service.execute(c.Go("room-101")).ok
    site.run(1.5, until_ended=False)
    exchanges: list[Exchange] = []
    site.control.subscribe(lambda event: isinstance(event, Exchange) and exchanges.append(event))
    for _ in range(2000):
        assert service.execute(c.Halt()).ok
        assert service.execute(c.StopMission()).ok
    site.run(0.05, until_ended=False)  # one tick
    assert site.control.mission is None
    assert len(exchanges) < 20, len(exchanges)
    site.run(2.0, until_ended=False)
    telemetry = service.telemetry
    assert telemetry is not None and telemetry.state is not None
    assert not telemetry.state.moving


def test_a_stop_after_a_mission_was_handed_over_ends_it_whatever_was_asked_before():
    service, site = service_on_site()
    assert service.execute(c.StopMission()).ok  # nothing runs: queued for the loop
    assert service.execute(c.Go("room-101")).ok
    assert service.execute(c.StopMission()).ok  # the same stop, asked after the go
    site.run(2.0, until_ended=False)
    assert site.control.mission is None
    last = service.situation().last_mission
    assert last is not None and last.end is not None


def test_each_operator_s_stop_holds_what_else_may_move_the_robot_until_released():
    service, _ = service_on_site()
    held: list[str] = []
    service.on_stop.append(lambda: held.append("held"))
    service.on_release.append(lambda: held.append("released"))
    service.execute(c.Halt())
    service.execute(c.StopMission())
    assert service.execute(c.Release()).ok
    assert held == ["held", "held", "released"]


def test_a_watcher_may_read_and_stop_but_not_move_and_a_hung_up_console_nothing():
    service, _ = service_on_site()
    service.attach("holder")
    service.attach("watcher")
    assert not service.execute(c.Press(Intent.FORWARD), "watcher").ok
    assert not service.execute(c.Door("dock-corridor", open=False), "watcher").ok
    assert service.execute(c.Send("get bulk_data"), "watcher").ok
    assert service.execute(c.Halt(), "watcher").ok
    service.detach("holder")
    assert not service.execute(c.Press(Intent.FORWARD), "holder").ok  # gone: not again


def test_numbers_that_are_not_numbers_are_refused():
    service, _ = service_on_site()
    assert not service.execute(c.Speed(to=math.nan)).ok
    assert not service.execute(c.Block(math.inf, 0.0)).ok


def test_a_scheduled_patrol_waits_while_an_operator_uses_the_robot():
    service, _ = service_on_site()
    service.execute(c.Speed(step=1))  # an operator's move of the controls, just now
    reply = service.run_scheduled("night")
    assert not reply.ok and "operator" in reply.text


def test_the_outbox_keeps_the_newest_telemetry_and_every_other_message():
    outbox = Outbox(limit=3)
    _, site = service_on_site()
    site.run(0.2, until_ended=False)
    snapshots: list[Telemetry] = []
    site.control.subscribe(lambda event: snapshots.append(event)
                           if isinstance(event, Telemetry) else None)  # fmt: skip
    site.run(0.2, until_ended=False)
    first, last = snapshots[0], snapshots[-1]
    outbox.put(first)
    outbox.put(Note("one"))
    outbox.put(last)
    outbox.put(Note("two"))
    assert [outbox.take(0.1) for _ in range(3)] == [Note("one"), Note("two"), last]
    assert outbox.take(0.01) is None


def test_an_outbox_too_far_behind_closes_rather_than_drop_an_answer():
    outbox = Outbox(limit=2)
    for text in ("a", "b", "c"):
        outbox.put(Note(text))
    assert outbox.overflowed
    assert [outbox.take(0.1), outbox.take(0.1), outbox.take(0.1)] == [Note("a"), Note("b"), None]
    assert outbox.closed


def test_a_rename_waits_for_a_mission_being_planned_and_is_then_refused(tmp_path):
    for suffix in (".yaml", ".pgm"):
        shutil.copy(EXAMPLE.with_suffix(suffix), tmp_path / f"care-home{suffix}")
    plan = load_floorplan(tmp_path / "care-home.yaml")
    navigator = Navigator(plan, walls_of(plan))
    site = Site(navigator)
    service = RobotService(site.control, DriveSetup.on_loop(site.control, navigator))
    plan_go = service.drives.go
    answers: list = []

    def go_while_an_operator_renames(room: str):
        mission = plan_go(room)
        renaming = threading.Thread(
            target=lambda: answers.append(service.execute(c.Name("kitchen", "cookhouse")))
        )
        renaming.start()
        renaming.join(0.3)
        answers.append("still waiting" if renaming.is_alive() else "done")
        service.renaming = renaming  # joined below
        return mission

    service.drives = replace(service.drives)
    object.__setattr__(service.drives, "go", go_while_an_operator_renames)
    assert service.execute(c.Go("kitchen")).ok
    service.renaming.join(5.0)
    assert answers[0] == "still waiting"
    refused = answers[1]
    assert not refused.ok and "not while a mission starts" in refused.text, refused
    assert "kitchen" in load_floorplan(tmp_path / "care-home.yaml").rooms


def test_every_request_there_is_has_a_handler_and_nothing_else_has_one():
    """Requests are dispatched by class through one table: a request class added to
    commands.py without a handler (or left out of REQUESTS, so it cannot cross the
    socket) fails here, not when a console first sends it."""
    defined = {value for value in vars(c).values()
               if isinstance(value, type) and issubclass(value, c.Request)
               and value is not c.Request}  # fmt: skip
    assert defined == set(c.REQUESTS)
    assert set(HANDLERS) == defined
