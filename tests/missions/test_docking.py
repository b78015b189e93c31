"""`go dock` and the charging detour of a patrol (missions/docking.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from giraff_console.missions.docking import (
    CHARGE_MAX_S,
    CHARGE_START_S,
    DOCK_RUN_M,
    SHORT_DOCK_RUN_M,
    ChargeLevels,
    ChargingDetour,
    GoToPose,
    Recharge,
    dock_arrival,
)
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol import Patrol, PatrolRun, Stop
from giraff_console.missions.undock import Undock
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.robot.battery import Battery
from giraff_console.robot.mission import DRIVING, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.sim.drive import TruePose
from tests.missions.site import LIMITS, PLAN, TICK, Site


@pytest.fixture(scope="module")
def shared_navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def test_the_dock_is_the_start_rooms_point_and_heading(shared_navigator):
    arrival = dock_arrival(shared_navigator)
    room = PLAN.rooms[PLAN.start]
    assert arrival.point == room.at
    assert arrival.heading == pytest.approx(math.radians(room.heading or 0.0))
    assert arrival.straight == DOCK_RUN_M


def test_a_dock_too_near_a_wall_for_the_long_run_gets_the_short_one():
    # The dock moved to 1.4 m from its room's south wall (y = 5): 1.5 m back from it is
    # beyond the wall, 0.8 m is not.
    room = PLAN.rooms[PLAN.start]
    near_wall = replace(room, at=(room.at[0], 6.4))
    plan = replace(PLAN, rooms={**PLAN.rooms, PLAN.start: near_wall})
    arrival = dock_arrival(Navigator(plan, walls_of(plan)))
    assert arrival.straight == SHORT_DOCK_RUN_M
    assert arrival.point == (room.at[0], 6.4)


def test_a_route_to_the_dock_ends_with_a_straight_run_along_its_heading(shared_navigator):
    arrival = dock_arrival(shared_navigator)
    far = PLAN.rooms[max(PLAN.rooms, key=lambda r: math.dist(PLAN.rooms[r].at, arrival.point))]
    planned = shared_navigator.planner.to_arrival(far.at, arrival)
    (ax, ay), (bx, by) = planned.path[-2], planned.path[-1]
    assert (bx, by) == arrival.point
    assert math.dist((ax, ay), (bx, by)) == pytest.approx(DOCK_RUN_M)
    assert math.atan2(by - ay, bx - ax) == pytest.approx(arrival.heading)
    assert planned.goal_heading == arrival.heading


def _place(site: Site, room: str) -> None:
    """Carry the robot to `room`, facing +x; the console is told where it is."""
    x, y = PLAN.rooms[room].at
    site.board.place(TruePose(x, y, 0.0))
    site.control.odometry.reset(Pose(x, y, 0.0))


@pytest.mark.parametrize("room", ["kitchen", "day-room"])
def test_go_dock_drives_onto_the_dock_square_on(room, shared_navigator):
    assert room in PLAN.rooms
    site = Site(shared_navigator)
    _place(site, room)
    arrival = dock_arrival(shared_navigator)
    mission = site.start(GoToPose(shared_navigator, "dock", arrival, site.pose, tick=TICK,
                                  limits=LIMITS, sense=site.sense))  # fmt: skip
    # The true pose at every tick: how far from the dock, and how far off its heading.
    trail: list[tuple[float, float]] = []
    end = site.clock.now() + 400
    while site.clock.now() < end and not site.ended:
        site.control.tick()
        site.clock.advance(TICK)
        pose = site.true_pose()
        off = math.degrees(abs(math.remainder(pose.heading - arrival.heading, math.tau)))
        trail.append((math.dist((pose.x, pose.y), arrival.point), off))
    assert site.ended == ["done"]
    report = mission.report(site.ends[0], site.true_pose()).as_json()
    assert report["error_m"] <= 0.03
    assert report["heading_error_deg"] <= 2.0
    # The last half of the run in, where no turn may reach, is driven square on.
    run_in = []
    for distance, off in reversed(trail):
        if distance > DOCK_RUN_M / 2 - 0.02:
            break
        run_in.append(off)
    assert len(run_in) > 5 and max(run_in) <= 2.0


class _Leg:
    """A mission that arrives after `steps` steps."""

    def __init__(self, name: str, steps: int = 3) -> None:
        self.name, self.steps, self.problem = name, steps, None
        self.progress = Progress(name, DRIVING)

    def step(self, now, state):
        self.steps -= 1
        return []

    @property
    def finished(self) -> bool:
        return self.steps <= 0

    def next_due(self):
        return None

    def pause(self, now):
        pass

    def resume(self, now):
        pass


def _detour(levels: list[float], left_off: Pose | None, status=ChargeStatus.FAST_CHARGING):
    made: list[str] = []
    notes: list[str] = []
    battery = {"now": Battery(ChargeStatus.NOT_DOCKED, levels[0])}

    def make(name: str):
        def mission(*args):
            made.append(name)
            return _Leg(name)

        return mission

    recharge = Recharge(lambda: battery["now"], ChargeLevels(25, 90), make("dock"),
                        make("undock"), make("back"))  # fmt: skip
    detour = ChargingDetour(recharge, battery["now"], left_off, notes.append, "patrol night")
    return detour, battery, made, notes


def test_the_detour_docks_charges_backs_out_and_returns_where_it_left_off():
    detour, battery, made, notes = _detour([18.0], Pose(1.0, 2.0, 0.0))
    assert "18 %, below 25 %" in notes[0]
    now = 0.0
    for _ in range(3):
        detour.step(now, None)
    assert made == ["dock"] and "docked at 18 %" in notes[-1]
    # Charging: nothing moves until the battery reaches the level.
    for level in (40.0, 70.0, 89.9):
        battery["now"] = Battery(ChargeStatus.FAST_CHARGING, level)
        now += 600
        assert detour.step(now, None) == []
        assert detour.progress == Progress("charging at the dock", f"{level:.0f} % of 90 %")
        assert detour.progress.line() == f"charging at the dock: {level:.0f} % of 90 %"
    assert made == ["dock"]
    battery["now"] = Battery(ChargeStatus.TRICKLE_CHARGING, 90.0)
    detour.step(now, None)
    assert made == ["dock", "undock"] and "charged to 90 %" in notes[-1]
    for _ in range(4):
        detour.step(now, None)
    assert made == ["dock", "undock", "back"]
    assert not detour.finished
    for _ in range(3):
        detour.step(now, None)
    assert detour.finished and detour.problem is None


def test_a_detour_before_a_room_stop_does_not_go_back():
    detour, battery, made, _ = _detour([10.0], None)
    for _ in range(3):
        detour.step(0.0, None)
    battery["now"] = Battery(ChargeStatus.TRICKLE_CHARGING, 95.0)
    for _ in range(5):
        detour.step(1.0, None)
    assert made == ["dock", "undock"] and detour.finished


def test_docked_but_not_charging_is_a_problem_that_says_what_to_check():
    detour, _, _, _ = _detour([10.0], None)
    for _ in range(3):
        detour.step(0.0, None)
    detour.step(CHARGE_START_S / 2, None)
    assert detour.problem is None
    detour.step(CHARGE_START_S + 1, None)
    assert detour.problem is not None and "stands on its dock" in detour.problem


def test_charge_levels_must_make_sense():
    with pytest.raises(ValueError):
        ChargeLevels(90, 25)
    with pytest.raises(ValueError):
        ChargeLevels(10, 101)


def test_low_ignores_a_charging_battery_and_unknown_levels():
    def recharge(battery):
        return Recharge(lambda: battery, ChargeLevels(25, 90), _Leg, _Leg, _Leg)

    assert recharge(Battery(ChargeStatus.NOT_DOCKED, 20.0)).low() is not None
    assert recharge(Battery(ChargeStatus.FAST_CHARGING, 20.0)).low() is None
    assert recharge(Battery(ChargeStatus.NOT_DOCKED, None)).low() is None
    assert recharge(None).low() is None
    assert recharge(Battery(ChargeStatus.NOT_DOCKED, 30.0)).low() is None


def test_a_patrol_that_runs_low_docks_charges_and_finishes_on_a_fast_clock(shared_navigator):
    # A later board, its battery just above the level: the first stop's drive takes it
    # below, so the patrol docks after that stop, charges to 30 % and carries on.
    site = Site(shared_navigator, board="&firmware=later&battery=0.256")
    _place(site, "kitchen")
    notes: list[str] = []
    reached: list[str] = []

    def go(room: str) -> GoTo:
        return GoTo(shared_navigator, room, site.pose, tick=TICK, limits=LIMITS,
                    sense=site.sense)  # fmt: skip

    recharge = Recharge(
        battery=lambda: site.control.battery,
        levels=ChargeLevels(25, 30),
        dock=lambda: GoToPose(shared_navigator, "dock", dock_arrival(shared_navigator),
                              site.pose, tick=TICK, limits=LIMITS, sense=site.sense),
        undock=lambda: Undock(0.3, LIMITS),
        back_to=lambda pose: pytest.fail("room stops need no way back"),
    )  # fmt: skip
    stops = [Stop(None, 2.0, room="day-room"), Stop(None, 2.0, room="kitchen")]
    run = PatrolRun(Patrol("night", 1, False, stops), {},
                    lambda stop: reached.append(stop.route_name), go=go, recharge=recharge,
                    pose=site.pose, notify=notes.append)  # fmt: skip
    site.start(run)
    docked_true = charged = None
    end = site.clock.now() + 3 * 3600
    while site.clock.now() < end and not site.ended:
        site.control.tick()
        site.clock.advance(TICK)
        if docked_true is None and any("docked at" in note for note in notes):
            docked_true = site.true_pose()
        if charged is None and any("carrying on" in note for note in notes):
            charged = site.board.battery_level
    assert site.ended == ["done"], (site.ended, notes)
    assert reached == ["day-room", "kitchen"]
    said = " | ".join(notes)
    assert "below 25 %: going to the dock" in said
    assert "charged to 30 %" in said
    # It docked where the simulator charges it, and really charged there.
    dock = dock_arrival(shared_navigator)
    assert docked_true is not None
    assert math.dist((docked_true.x, docked_true.y), dock.point) <= 0.03
    assert charged is not None and charged >= 0.30
    assert said.index("docked at") < said.index("carrying on")


def test_go_dock_on_the_dock_already_stays_there(shared_navigator):
    site = Site(shared_navigator)  # put down on its dock, the start room's point
    sent: list[str] = []
    site.link.add_observer(lambda exchange: sent.append(exchange.command))
    site.start(GoToPose(shared_navigator, "dock", dock_arrival(shared_navigator), site.pose,
                        tick=TICK, limits=LIMITS))  # fmt: skip
    site.run(5)
    assert site.ended == ["done"]
    assert not [command for command in sent if command.startswith("set p")]


def test_a_charger_that_never_gets_there_is_a_problem_not_a_wait_all_night():
    detour, battery, _, _ = _detour([10.0], None)
    for _ in range(3):
        detour.step(0.0, None)
    battery["now"] = Battery(ChargeStatus.TRICKLE_CHARGING, 60.0)
    detour.step(CHARGE_MAX_S - 1, None)
    assert detour.problem is None
    detour.step(CHARGE_MAX_S + 1, None)
    assert detour.problem is not None and "check the charger" in detour.problem
    assert "60 %" in detour.problem
