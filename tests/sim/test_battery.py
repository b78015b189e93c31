"""The battery of a later board: drained by time and travel, charged on the dock."""

from __future__ import annotations

import math

import pytest

from giraff_console.data_folders import example_floorplan
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol.charger import ChargeStatus, parse_charger
from giraff_console.runtime.sim_site import SimulatedSite
from giraff_console.sim import BoardConfig, TruePose
from giraff_console.sim.battery import (
    CAPACITY_WS,
    FAST_CHARGE_W,
    IDLE_W,
    MOTION_J_PER_M,
    TRICKLE_CHARGE_W,
)
from giraff_console.sim.firmware import FIRMWARES
from tests.conftest import SimBench

DOCK = TruePose(2.0, 1.0, math.radians(90))


def later(level: float = 1.0) -> SimBench:
    return SimBench(BoardConfig(firmware=FIRMWARES["later"], battery=level))


def charger(sim: SimBench) -> dict[str, float]:
    """One full turn of the six readings, and the status of the last."""
    values: dict[str, float] = {}
    for _ in range(6):
        reading = parse_charger(sim.cmd("get charger_data"))
        values[reading.parameter] = reading.value
        values["status"] = reading.status
    return values


def test_the_battery_drains_with_time():
    sim = later()
    sim.advance(1000.0)
    assert sim.board.battery_level == pytest.approx(1 - 1000 * IDLE_W / CAPACITY_WS)
    assert charger(sim)["W"] == -1000 * IDLE_W


def test_the_battery_drains_with_distance_too():
    idle, driven = later(), later()
    driven.run("set r 1", "set a 0.5", "set v 0.4", "set p 10")
    for sim in (idle, driven):
        sim.advance(60.0)
    drawn = idle.board.battery_level - driven.board.battery_level
    assert drawn * CAPACITY_WS == pytest.approx(10 * MOTION_J_PER_M, rel=1e-6)


def test_the_current_is_negative_while_discharging_and_grows_with_speed():
    sim = later(0.5)
    standing = charger(sim)
    assert standing["status"] == ChargeStatus.NOT_DOCKED
    assert standing["B"] == pytest.approx(22.0 + 3.6 * 0.5, abs=0.01)
    assert standing["b"] == pytest.approx(-IDLE_W / standing["B"], rel=1e-3)
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p 10")
    sim.advance(5.0)
    assert charger(sim)["b"] < standing["b"]


def docked(level: float) -> SimBench:
    sim = later(level)
    sim.board.dock = DOCK
    sim.board.place(DOCK)
    return sim


def test_the_robot_charges_fast_on_the_dock_up_to_90_percent_then_trickles():
    sim = docked(0.5)
    reading = charger(sim)
    assert reading["status"] == ChargeStatus.FAST_CHARGING
    assert reading["D"] == 28.0 and reading["d"] > 0 and reading["b"] > 0
    assert reading["B"] == pytest.approx(22.0 + 3.6 * 0.5 + 0.8, abs=0.01)
    sim.advance(1000.0)
    assert sim.board.battery_level == pytest.approx(0.5 + 1000 * FAST_CHARGE_W / CAPACITY_WS)
    to_90 = (0.9 - sim.board.battery_level) * CAPACITY_WS / FAST_CHARGE_W
    sim.advance(to_90 + 100.0)
    assert sim.board.battery_level == pytest.approx(0.9 + 100 * TRICKLE_CHARGE_W / CAPACITY_WS)
    assert charger(sim)["status"] == ChargeStatus.TRICKLE_CHARGING
    sim.advance(10 * 3600.0)
    assert sim.board.battery_level == 1.0
    full = charger(sim)
    assert (full["W"], full["b"], full["status"]) == (0.0, 0.0, ChargeStatus.TRICKLE_CHARGING)


@pytest.mark.parametrize(
    "pose",
    [
        TruePose(DOCK.x + 0.04, DOCK.y, DOCK.heading),  # within the contacts
        TruePose(DOCK.x, DOCK.y, DOCK.heading + math.radians(4) + 2 * math.tau),
    ],
)
def test_near_enough_is_docked(pose):
    sim = docked(0.5)
    sim.board.place(pose)
    assert charger(sim)["status"] == ChargeStatus.FAST_CHARGING


@pytest.mark.parametrize(
    "pose",
    [
        TruePose(DOCK.x + 0.06, DOCK.y, DOCK.heading),
        TruePose(DOCK.x, DOCK.y, DOCK.heading + math.radians(6)),
        TruePose(DOCK.x, DOCK.y, DOCK.heading + math.pi),  # backwards onto it
    ],
)
def test_off_the_dock_it_does_not_charge(pose):
    sim = docked(0.5)
    sim.board.place(pose)
    reading = charger(sim)
    assert (reading["status"], reading["D"], reading["d"]) == (ChargeStatus.NOT_DOCKED, 0, 0)
    sim.advance(100.0)
    assert sim.board.battery_level < 0.5


def test_driving_off_the_dock_stops_the_charge():
    sim = docked(0.5)
    sim.advance(100.0)
    sim.run("set r 1", "set a 0.5", "set v 0.4", "set p -1")
    sim.advance(100.0)
    level = sim.board.battery_level
    assert charger(sim)["status"] == ChargeStatus.NOT_DOCKED
    sim.advance(100.0)
    assert sim.board.battery_level == pytest.approx(level - 100 * IDLE_W / CAPACITY_WS)


def test_the_site_puts_the_dock_at_the_start_room():
    plan = load_floorplan(example_floorplan())
    start = Navigator(plan, walls_of(plan), 0.3).start_pose
    sim = later(0.5)
    SimulatedSite(sim.board, plan, start)
    assert sim.board.dock == TruePose(start.x, start.y, start.heading)
    assert charger(sim)["status"] == ChargeStatus.FAST_CHARGING


def test_a_board_power_cycle_keeps_the_battery():
    sim = later(0.4)
    sim.board.power_off()
    assert sim.board.battery_level == pytest.approx(0.4)
