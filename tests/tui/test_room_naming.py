"""Naming the rooms of a scanned plan from the console (issue 16, item 2; §2.6.3):
`name room-3 kitchen`, or `mark kitchen` where the robot stands; the plan is saved."""

from __future__ import annotations

import time

from giraff_console.planning.floorplan import load_floorplan
from tests.planning.scanned_building import write_scanned_plan
from tests.tui.conftest import Rig

SIZE = (100, 30)


async def said(rig: Rig, pilot, text: str, timeout: float = 10.0) -> str:
    """The status log's lines once one has `text` in it (a rename runs in a worker)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        lines = "\n".join(rig.app.status_log.texts)
        if text in lines:
            return lines
        await pilot.pause(0.02)
    raise AssertionError(f"{text!r} never said; the log: {rig.app.status_log.texts}")


async def test_name_renames_a_room_everywhere_and_saves_the_plan(tmp_path):
    path = write_scanned_plan(tmp_path)
    rig = Rig(floorplan=path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        rig.app.run_command("name east-room kitchen")
        await said(rig, pilot, f"room east-room is now kitchen; saved in {path}")
        assert "kitchen" in load_floorplan(path).rooms
        assert "kitchen" in rig.navigator.room_ids()
        assert rig.app._scene is not None
        assert "kitchen" in [label for label, _ in rig.app._scene.labels]
        assert "east-room" not in [label for label, _ in rig.app._scene.labels]
        rig.app.run_command("go kitchen")
        await said(rig, pilot, "route to kitchen:")


async def test_a_door_shut_before_a_rename_stays_shut_and_keeps_its_id(tmp_path):
    path = write_scanned_plan(tmp_path)  # its doors have no ids: named by their rooms
    rig = Rig(floorplan=path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        rig.app.run_command("close corridor-east-room")
        await said(rig, pilot, "door corridor-east-room closed")
        rig.app.run_command("name east-room kitchen")
        await said(rig, pilot, "room east-room is now kitchen")
        assert rig.navigator.planner.graph.closed == {"corridor-east-room"}
        assert rig.navigator.state.closed == {"corridor-east-room"}
        assert "corridor-east-room" in {door.id for door in load_floorplan(path).doors}
        rig.app.run_command("open corridor-east-room")
        await said(rig, pilot, "door corridor-east-room open")


async def test_mark_names_the_room_the_robot_stands_in(tmp_path):
    path = write_scanned_plan(tmp_path)  # the robot starts in the corridor
    rig = Rig(floorplan=path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        rig.app.run_command("mark hall")
        await said(rig, pilot, "room corridor (where the robot stands) is now hall")
        plan = load_floorplan(path)
        assert plan.start == "hall" and "corridor" not in plan.rooms


async def test_a_rename_refused_says_why_and_changes_nothing(tmp_path):
    path = write_scanned_plan(tmp_path)
    before = path.read_text()
    rig = Rig(floorplan=path)
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        rig.app.run_command("name east-room west-room")
        await said(rig, pilot, "name: there is a room 'west-room' already")
        rig.app.run_command("name east-room")
        await said(rig, pilot, "refused: usage: name ROOM NEW (name room-3 kitchen)")
        rig.app.run_command("go west-room")
        await said(rig, pilot, "route to west-room:")
        rig.app.run_command("name east-room kitchen")  # the loop has not started it yet
        await said(rig, pilot, "name: not while a mission starts")
        await rig.run(pilot, 0.1)
        rig.app.run_command("name east-room kitchen")
        await said(rig, pilot, "name: not while go west-room runs")
    assert path.read_text() == before


async def test_a_rename_says_which_patrols_still_stop_at_the_old_name(tmp_path):
    path = write_scanned_plan(tmp_path)
    rig = Rig(floorplan=path, recordings=tmp_path / "recordings")
    routes = tmp_path / "routes"
    routes.mkdir(exist_ok=True)
    (routes / "night.patrol.yaml").write_text("rounds: 1\nstops:\n  - room: east-room\n")
    (routes / "day.patrol.yaml").write_text("rounds: 1\nstops:\n  - room: west-room\n")
    async with rig.app.run_test(size=SIZE) as pilot:
        await rig.run(pilot, 0.1)
        rig.app.run_command("name east-room kitchen")
        lines = await said(rig, pilot, "room east-room is now kitchen")
        assert "patrols night still stop at east-room: change them to kitchen" in lines
        assert "day" not in lines.split("is now kitchen")[1]
        rig.app.run_command("mark hall")
        lines = await said(rig, pilot, "room corridor (where the robot stands) is now hall")
        assert "`name hall corridor` undoes it" in lines
