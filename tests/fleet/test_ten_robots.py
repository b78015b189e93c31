"""Ten robots on one broker and the fleet view (issue 28, the first Done-when): each a
runtime.Robot with its fleet link in the walled wing; the view lists all ten with their
live state, an operator sends each one somewhere from it with its keys, and all ten
arrive, say so in `state`, and stand where the simulator's true pose says."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from textual.widgets import Input

from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.master import FleetMaster
from giraff_console.fleet.vocabulary import ConnectionState
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.tui.fleet.app import FleetView
from giraff_console.tui.map_scene import plan_scene
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import fleet_robots

# Ten robots' simulators at four times real time with their cameras' markers: the
# machine's two cores are what bounds it, not the robots.
pytestmark = pytest.mark.timeout(330)

ROBOTS = 10
# The rooms nearest the dock, each robot one of them (each robot has a building of its
# own: the simulator has no other robots in it).
ROOMS = ["w-15", "treatment", "w-14", "hub", "w-08"]
ARRIVE_S = 240.0
# The simulated cameras at half the frames and a quarter of the pixels (`--eye-fps 5
# --eye-size 400x300`): ten robots' markers are what the two cores spend this test on
# (118 s with the defaults, 65 s so), and the markers are still found at every goal.
EYE = (5.0, "400x300")
ARRIVAL_M = 0.10


async def until(pilot, holds: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not holds():
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        await pilot.pause(0.1)


async def test_ten_robots_are_listed_sent_from_the_view_and_all_arrive(
    broker: Broker, wing: Path, tmp_path: Path
):
    plan = load_floorplan(wing)
    walls = walls_of(plan)
    assert walls is not None
    goals = {f"giraff/g{n:02d}": ROOMS[(n - 1) % len(ROOMS)] for n in range(1, ROBOTS + 1)}
    with (
        fleet_robots(broker, wing, tmp_path, ROBOTS, eye=EYE) as robots,
        FleetMaster(BrokerAddress.parse(broker.url)) as master,
    ):
        app = FleetView(master, plan=plan, scene=plan_scene(plan, walls), cursor_blink=False)
        async with app.run_test(size=(120, 40)) as pilot:

            def listed() -> bool:
                fleet = master.fleet()
                return len(fleet.vehicles) == ROBOTS and all(
                    v.connection is ConnectionState.ONLINE
                    and v.state is not None
                    and v.state.last_node_id == "dock"
                    for v in fleet.vehicles
                )

            await until(pilot, listed, 30, "ten robots on the dock")
            await until(pilot, lambda: app.table.row_count == ROBOTS, 5, "ten rows")
            for row in range(ROBOTS):
                # The row chosen as a click would; the room typed into the prompt `g`
                # opens. Each key the pilot presses waits for the process to idle, which
                # ten robots in it never do (two seconds a key).
                app.table.move_cursor(row=row)
                vehicle = app.table.selected
                assert vehicle is not None and vehicle.name == f"giraff/g{row + 1:02d}"
                await pilot.press("g")
                app.screen.query_one("#room", Input).value = goals[vehicle.name]
                await pilot.press("enter")
            sent = [line for line in (s.text for s in app.log_view.lines) if "sent" in line]
            assert len(sent) >= ROBOTS, sent

            def arrived() -> bool:
                fleet = master.fleet()
                return all(
                    (
                        v.state is not None
                        and v.state.arrived
                        and v.state.last_node_id == goals[v.id.name]
                    )
                    for v in fleet.vehicles
                )

            await until(pilot, arrived, ARRIVE_S, "ten arrivals")
            # The view shows it too: every row's mission says it got there.
            await until(
                pilot,
                lambda: all(
                    f"at {room}" in app.table.get_cell(name, "mission").plain
                    for name, room in goals.items()
                ),
                5,
                "ten rows at their rooms",
            )
        for robot in robots:
            true = robot.robot.true_pose()
            assert true is not None
            goal = plan.rooms[goals[robot.id.name]].at
            assert math.dist((true.x, true.y), goal) <= ARRIVAL_M, robot.id.name
            assert robot.vehicle.bad == 0 and robot.vehicle.dropped == 0
