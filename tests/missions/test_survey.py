"""The survey (missions/survey.py): its tour (a look round in each room, the map redrawn
at the end of each, a room not reached tried once more before the dock), and the
markers it writes flat on their walls."""

from __future__ import annotations

import math
from dataclasses import replace
from operator import attrgetter

import numpy as np
import pytest

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.survey import GOES_ON_AFTER, Tour, _onto_wall, redraw_map
from giraff_console.planning.landmarks import MarkerWalls
from giraff_console.planning.route_planner import walls_of
from giraff_console.planning.walls import WallSegment
from giraff_console.protocol.codec import Command
from giraff_console.robot.ekf import Observation
from giraff_console.robot.localisation import Localisation, start_covariance
from giraff_console.robot.marker_map import MarkerState
from giraff_console.robot.mission import Outcome, Progress
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.pose_graph import SurveyedMarker, Wall
from giraff_console.robot.survey_log import SurveyLog
from tests.missions.site import LIMITS, PLAN, TICK, Site


class Leg:
    """A room's mission that ends at once, as `outcome` says."""

    def __init__(self, room: str, outcome: Outcome) -> None:
        self.name = f"go {room}"
        self.outcome = outcome
        self.problem = None if outcome.arrived else f"{outcome.value} on the way"
        self.detail = "there" if outcome.arrived else ""
        self.finished = outcome.arrived

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        return []

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        pass

    def resume(self, now: float) -> None:
        pass

    @property
    def progress(self) -> Progress:
        return Progress(self.name, "")


@pytest.fixture(scope="module")
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def run(navigator: Navigator, rooms: list[str],
        outcomes: dict[str, list[Outcome]]) -> tuple[Tour, list[str], int]:  # fmt: skip
    """The tour on the simulated board, to its end, each room's leg ending at once as
    `outcomes` says (arrived by default); the rooms set off for, in order, and how many
    look rounds it ended (the callback's calls)."""
    site = Site(navigator)
    set_off: list[str] = []
    looks = []

    def go(room: str) -> Leg:
        set_off.append(room)
        return Leg(room, outcomes.get(room, [Outcome.ARRIVED]).pop(0))

    tour = Tour(rooms, go, site.pose, LIMITS, TICK,  # type: ignore[arg-type]
                looked_round=lambda: looks.append(1))  # fmt: skip
    site.start(tour)
    site.run(300.0)
    assert site.ended, "the tour never ended"
    return tour, set_off, len(looks)


def test_each_room_is_looked_round_and_the_map_redrawn_at_the_end_of_each(navigator) -> None:
    tour, set_off, looks = run(navigator, ["kitchen", "lounge", "dock"], {})
    assert tour.finished and tour.problem is None
    assert set_off == ["kitchen", "lounge", "dock"]
    # One on the dock before setting off, and one in each room.
    assert looks == 4
    assert tour.not_reached == []


@pytest.mark.parametrize("outcome", sorted(GOES_ON_AFTER, key=attrgetter("value")))
def test_a_room_not_reached_is_tried_once_more_before_the_dock(navigator, outcome: Outcome) -> None:
    tour, set_off, _ = run(navigator, ["kitchen", "lounge", "dock"],
                           {"kitchen": [outcome, Outcome.ARRIVED]})  # fmt: skip
    assert tour.finished and tour.problem is None
    assert set_off == ["kitchen", "lounge", "kitchen", "dock"]
    assert tour.not_reached == []


def test_a_room_not_reached_twice_is_left_out_and_the_tour_goes_on(navigator) -> None:
    tour, set_off, _ = run(navigator, ["kitchen", "lounge", "dock"],
                           {"kitchen": [Outcome.STALLED, Outcome.LOST]})  # fmt: skip
    assert tour.finished and tour.problem is None
    assert set_off == ["kitchen", "lounge", "kitchen", "dock"]
    assert tour.not_reached == ["kitchen"]


def test_the_dock_not_reached_is_tried_once_more(navigator) -> None:
    tour, set_off, _ = run(
        navigator, ["kitchen", "dock"], {"dock": [Outcome.BLOCKED, Outcome.ARRIVED]}
    )
    assert tour.finished and tour.problem is None
    assert set_off == ["kitchen", "dock", "dock"]
    assert tour.not_reached == []


def test_anything_else_ends_the_survey(navigator) -> None:
    tour, set_off, _ = run(navigator, ["kitchen", "lounge", "dock"], {"kitchen": [Outcome.FAILED]})
    assert set_off == ["kitchen"]
    assert tour.problem is not None and tour.problem.startswith("kitchen:")


def test_a_redrawn_map_moves_the_markers_and_the_robot_where_the_graph_puts_them() -> None:
    """The robot drives 1 m straight at a marker on a wall 3 m ahead, seeing it all the
    way; the filter, drifted 0.3 m along the wall, learnt the marker there. The graph,
    with every sighting against the whole path, puts both back, and the robot keeps
    the casters' turn still to come."""
    odometry = Odometry()
    localisation = Localisation(odometry)
    start = Pose(0.0, 0.0, 0.0)
    localisation.place(start, start_covariance())
    log = SurveyLog(start, odometry.wheel_base)
    wall = Wall((3.0, -2.0), (3.0, 2.0), facing=math.pi)
    localisation.start_survey(log, [(wall.a, wall.b)])
    drifted, sure = Pose(0.0, 0.3, 0.0), np.diag([1e-4, 1e-4, 1e-6])
    for step in range(21):
        x = step * 0.05
        if step:
            log.wheels(0.05, 0.05)
        seen = Observation(7, 3.0 - x, 0.0, math.pi, float(step))
        log.frame([seen])
        localisation.map.learn(7, Pose(x, drifted.y, 0.0), sure, seen)
    assert localisation.map.beliefs[7].pose.y > 0.25  # the drift learnt into the marker
    base = odometry.wheel_base
    localisation.filter.reset(Pose(1.0, 0.3, 0.0), sure)
    for _ in range(36):  # a full turn on the spot: the casters will turn it on setting off
        arc = math.radians(10.0) * base / 2
        localisation.filter.predict(-arc, arc, base, turned_in_place=True)
    casters = localisation.filter.caster_expected
    assert abs(casters) > 0.01

    redraw_map(localisation, [wall])

    marker = localisation.map.beliefs[7]
    assert marker.state is MarkerState.KNOWN
    assert math.hypot(marker.pose.x - 3.0, marker.pose.y) < 0.03
    robot = localisation.filter.pose
    assert math.hypot(robot.x - 1.0, robot.y) < 0.03
    assert localisation.filter.sigma_m < 0.1
    assert localisation.filter.caster_expected == pytest.approx(casters)


def found(x: float, y: float, facing_deg: float, sigma_across: float = 0.01,
          held: Wall | None = None) -> SurveyedMarker:  # fmt: skip
    """A marker as a solve leaves it, known to `sigma_across` (either way), `held` to a
    wall or not."""
    covariance = np.diag([sigma_across**2, sigma_across**2, math.radians(1.0) ** 2])
    return SurveyedMarker(1, Pose(x, y, math.radians(facing_deg)), covariance, 5, True, held)


def test_a_marker_solved_a_little_off_its_wall_is_written_flat_on_it() -> None:
    """3 cm into a grid's wall and 2 degrees askew, as a solve can leave it: on the
    wall's line, square to it, the side it faces kept. One on no wall, or only beside
    the end of one, stays where it was found."""
    walls = MarkerWalls([WallSegment((0.0, 0.0), (4.0, 0.0), facing=90.0)])
    at, facing = _onto_wall(found(2.0, -0.03, 88.0), walls)
    assert at == pytest.approx((2.0, 0.0))
    assert facing == pytest.approx(90.0)
    assert _onto_wall(found(2.0, 1.0, 88.0), walls) == ((2.0, 1.0), pytest.approx(88.0))
    assert _onto_wall(found(4.1, -0.03, 88.0), walls)[0] == (4.1, -0.03)


def test_a_marker_goes_on_the_face_it_looks_out_of_within_what_the_survey_knows() -> None:
    """A grid's wall has two faces; a marker facing north goes on the north face, not on
    the nearer south one. 7 cm off, it goes there only if the solve held it to a wall
    and knew it no better across it than 3.5 cm; never if the solve found its
    sightings put it off the wall it was given."""
    south = WallSegment((0.0, 0.0), (4.0, 0.0), facing=270.0)
    north = WallSegment((0.0, 0.1), (4.0, 0.1), facing=90.0)
    walls = MarkerWalls([south, north])
    at, facing = _onto_wall(found(2.0, 0.06, 91.0), walls)
    assert at == pytest.approx((2.0, 0.1)) and facing == pytest.approx(90.0)
    held = Wall(north.a, north.b)
    assert _onto_wall(found(2.0, 0.17, 91.0, 0.04, held), walls)[0] == pytest.approx((2.0, 0.1))
    assert _onto_wall(found(2.0, 0.17, 91.0, 0.02, held), walls)[0] == (2.0, 0.17)
    assert _onto_wall(found(2.0, 0.17, 91.0, 0.04), walls)[0] == (2.0, 0.17)
    rejected = replace(found(2.0, 0.13, 91.0, 0.04, held), wall=None, wall_rejected=True)
    assert _onto_wall(rejected, walls)[0] == (2.0, 0.13)
