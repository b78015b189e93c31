"""`go ROOM` on the simulated board in the example care home, on a virtual clock.

Distances and headings are measured from the simulator's true pose, which the console
never reads.
"""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import astuple

import pytest

from giraff_console.missions.navigation import Navigator
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.mission import ARRIVED, DRIVING, PAUSED, Outcome, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import Telemetry
from tests.listening import only
from tests.missions.site import LIMITS, PLAN, TICK, Site


@pytest.fixture(scope="module")
def shared_navigator() -> Navigator:
    """One navigator for the runs without obstacles: legs measured once serve them all."""
    return Navigator(PLAN, walls_of(PLAN))


@pytest.fixture
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def heading_error_deg(pose: Pose, room: str) -> float:
    heading = PLAN.rooms[room].heading
    if heading is None:
        return 0.0
    return math.degrees(abs(math.remainder(pose.heading - math.radians(heading), 2 * math.pi)))


@pytest.mark.parametrize("room", sorted(set(PLAN.rooms) - {PLAN.start}))
def test_go_reaches_every_room_precisely_smoothly_and_nearly_as_fast_as_the_optimum(
    room, shared_navigator
):
    site = Site(shared_navigator)
    mission = site.go(room)
    site.run(400)
    assert site.ended == ["done"]
    pose = site.true_pose()
    report = mission.report(site.ends[0], pose).as_json()
    # No markers to confirm it by: the odometry's arrival, said to be unconfirmed.
    assert report["outcome"] == "arrived_unverified" and not report["arrived"]
    assert report["error_m"] <= 0.03
    assert heading_error_deg(pose, room) <= 2.0
    assert report["gear_jumps"] == 0
    assert report["max_jerk"] <= LIMITS.j_max + 1e-9
    assert report["duration_s"] <= 1.15 * report["time_optimal_s"]


@pytest.mark.parametrize("firmware", ["later", "giraff-x"])
@pytest.mark.parametrize("room", ["kitchen", "room-113", "activity-room"])
def test_go_reaches_rooms_as_precisely_on_later_firmware(room, firmware, shared_navigator):
    # Increments instead of totals, and on a Giraff-X curves sent as one twm each.
    site = Site(shared_navigator, board=f"&firmware={firmware}")
    mission = site.go(room)
    site.run(400)
    assert site.ended == ["done"]
    pose = site.true_pose()
    report = mission.report(site.ends[0], pose).as_json()
    assert report["error_m"] <= 0.03
    assert heading_error_deg(pose, room) <= 2.0
    assert report["gear_jumps"] == 0


def test_the_runaway_is_bounded_at_every_tick_of_a_go(shared_navigator):
    """Were the console to die after any tick, the board would stop within 0.3 m: the
    board's motion is copied at each tick and run on alone for ten seconds."""
    site = Site(shared_navigator)
    site.go("kitchen")
    worst = 0.0
    ticks = 0
    while not site.ended:
        site.control.tick()
        site.clock.advance(TICK)
        ticks += 1
        if ticks % 4:
            continue
        drive = copy.deepcopy(site.board.drive)
        before = drive.pose
        drive.advance(site.clock.now() + 10.0)
        worst = max(worst, math.dist((before.x, before.y), (drive.pose.x, drive.pose.y)))
    assert site.ended == ["done"] and ticks > 1000
    assert worst <= 0.3 + 1e-9  # the runaway rule, to the float rounding of 0.3 m


def test_a_corridor_blocked_ahead_is_replanned_through_other_doors_and_reached(navigator):
    site = Site(navigator)
    site.site.surroundings.block(20.0, 11.0, size=1.9)  # a trolley across the corridor
    mission = site.go("room-113")
    site.run(600)
    assert site.ended == ["done"]
    assert mission.replans >= 1
    assert navigator.state.obstacles  # what the range finder saw is on the map
    # Round by the lobby and the north corridor, into the corridor's east end.
    assert "north-corridor" in mission.planned.route.rooms
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), PLAN.rooms["room-113"].at) <= 0.03


def test_a_door_blocked_mid_route_is_gone_round(navigator):
    site = Site(navigator)
    mission = site.go("day-room")
    site.run(20)  # along the corridor
    assert not site.ended
    site.site.surroundings.block(36.0, 12.0, size=1.6)  # the day room's corridor door
    site.run(600)
    assert site.ended == ["done"]
    assert mission.replans >= 1
    assert "day-room-corridor" not in mission.planned.route.doors
    assert math.dist((site.true_pose().x, site.true_pose().y), (36, 16)) <= 0.03


def test_closing_a_door_on_the_route_while_driving_goes_round_it(navigator):
    site = Site(navigator)
    mission = site.go("day-room")
    site.run(15)
    navigator.close("day-room-corridor", site.control.odometry.pose)
    site.run(600)
    assert site.ended == ["done"]
    assert "day-room-corridor" not in mission.planned.route.doors


def test_cancelling_stops_within_the_braking_distance(shared_navigator):
    site = Site(shared_navigator)
    site.go("room-113")
    site.run(20)  # well along the corridor
    while site.board.drive.velocity < LIMITS.v_max - 0.005:  # cruising
        site.run(TICK)
    speed = site.board.drive.velocity
    at = site.true_pose()
    site.control.stop_mission("stopped by the operator")
    site.run(5, until_ended=False)
    stopped = site.true_pose()
    assert site.ended == ["stopped by the operator"]
    assert site.board.drive.velocity == 0
    # The braking distance from 0.4 m/s at 0.5 m/s^2, 16 cm, plus a tick of reaction.
    assert math.dist((at.x, at.y), (stopped.x, stopped.y)) <= speed**2 / (2 * 0.5) + speed * TICK


def test_a_stall_that_lasts_is_tried_round_and_then_ends_the_mission_stopped(shared_navigator):
    # The wheels stall whichever way they are driven: backing off stalls too.
    site = Site(shared_navigator)
    mission = site.go("room-113")
    site.run(10)
    site.board.stall(8.0)
    site.run(8)
    assert site.ended and "touched something ahead and behind" in site.ended[0]
    assert mission.outcome is Outcome.STALLED and mission.contacts == 1
    # Once the wheels turn again, the board's last move is a stop.
    stalled_at = site.true_pose()
    site.run(12, until_ended=False)
    assert site.board.drive.velocity == 0
    assert math.dist(astuple(stalled_at)[:2], astuple(site.true_pose())[:2]) <= 0.3


def test_a_momentary_stall_is_backed_off_and_the_goal_still_reached(shared_navigator):
    site = Site(shared_navigator)
    mission = site.go("room-113")
    site.run(10)
    site.board.stall(1.5)
    site.run(400)
    assert site.ended == ["done"] and mission.contacts == 1
    assert math.dist(PLAN.rooms["room-113"].at, astuple(site.true_pose())[:2]) <= 0.03


def test_an_estop_stops_the_mission(shared_navigator):
    site = Site(shared_navigator)
    site.go("room-113")
    site.run(10)
    site.board.set_estop(True)
    site.run(2)
    assert site.ended == ["stopped by ESTOP"]


@pytest.mark.parametrize("seed", range(1, 9))
def test_with_imperfections_dead_reckoning_never_claims_a_confirmed_arrival(seed, shared_navigator):
    """A real robot's errors: the odometry sees the wheels' distance errors and steers
    them out; stalls are backed off and tried again; ESTOPs end the mission. Without
    markers nothing confirms where it ends: never ARRIVED. This route turns on no spot,
    so the casters' unseen turn (§3.2.1.5) spoils it only after a contact's new plan."""
    site = Site(shared_navigator, imperfect=seed)
    mission = site.go("kitchen")
    site.run(400)
    assert site.ended
    end = site.ends[0]
    report = mission.report(end, site.true_pose()).as_json()
    assert not report["arrived"]
    assert end.outcome in (Outcome.ARRIVED_UNVERIFIED, Outcome.ESTOP, Outcome.STALLED), end
    assert report["outcome"] == end.outcome.value
    if end.outcome is Outcome.ARRIVED_UNVERIFIED:
        assert report["error_m"] <= 0.05 or report["contacts"] > 0


def test_go_publishes_its_progress_as_data_the_metres_left_falling_to_arrival(shared_navigator):
    site = Site(shared_navigator)
    shown: list[Progress | None] = []
    site.control.subscribe(only(Telemetry, lambda telemetry: shown.append(telemetry.mission)))
    mission = site.go("kitchen")
    site.run(10)
    site.control.pause_mission(True)
    site.run(2, until_ended=False)
    paused = mission.progress
    site.control.pause_mission(False)
    site.run(400)
    assert site.ended == ["done"]
    driving = [p for p in shown if p is not None and p.state == DRIVING]
    assert len(driving) > 100 and all(p.name == "go kitchen" for p in driving)
    # The whole plan at the start, nothing of it at the end, never more left than before
    # within one plan (pausing plans again, from where the robot stopped).
    first, last = driving[0], driving[-1]
    assert first.left_m == pytest.approx(first.total_m) and first.total_m > 5
    assert last.left_m is not None and last.left_m < 0.1
    for before, after in itertools.pairwise(driving):
        if after.total_m == before.total_m:
            # Within a micron: the board's last move settles to its own rounding.
            assert after.left_m <= before.left_m + 1e-6
    # An ETA while driving, never sooner than the metres left at full speed.
    assert all(p.eta_s is not None and p.eta_s >= p.left_m / LIMITS.v_max for p in driving)
    assert driving[len(driving) // 2].eta_s < first.eta_s
    # Paused: the metres left, and no ETA.
    assert paused.state == PAUSED and paused.eta_s is None and 0 < paused.left_m < first.left_m
    assert paused.line().startswith("go kitchen ") and paused.line().endswith(
        f"paused, {paused.left_m:.1f} m left"
    )
    assert mission.progress == Progress("go kitchen", ARRIVED)
    assert shown[-1] is None  # ended: the telemetry carries no mission
