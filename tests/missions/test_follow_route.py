"""Taught routes followed closed-loop, and patrols that go to rooms, in the simulated
care home."""

from __future__ import annotations

import math

import pytest

from giraff_console.missions.follow_route import FollowRoute
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol import Patrol, PatrolRun, Stop
from giraff_console.missions.route import PathSample, Route
from giraff_console.planning.room_graph import PlanningError
from giraff_console.planning.route_planner import walls_of
from tests.missions.site import LIMITS, PLAN, TICK, Site


@pytest.fixture
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def taught_route() -> Route:
    """Out of the dock, along the corridor to the nurse station's door, as an operator
    drove it: a wobbly line of dead-reckoned samples every 0.1 m."""
    path = [PathSample(0.25 * i, 2.0, 7.0 + 0.1 * i, math.pi / 2) for i in range(40)]  # to y 10.9
    path += [PathSample(10 + 0.25 * i, 2.0 + 0.1 * i, 10.9 + 0.01 * math.sin(i), 0.0)
             for i in range(1, 31)]  # fmt: skip
    return Route("dock-out", "T", None, {}, [], path, [], 20.0)


def test_a_taught_route_is_followed_along_its_path_to_its_end(navigator):
    site = Site(navigator)
    route = taught_route()
    site.start(FollowRoute(route, navigator, site.pose, tick=TICK, limits=LIMITS,
                           sense=site.sense))  # fmt: skip
    site.run(120)
    assert site.ended == ["done"]
    end = route.path[-1]
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), (end.x, end.y)) <= 0.03
    assert abs(math.remainder(pose.heading - end.heading, 2 * math.pi)) <= math.radians(2)


def test_a_route_is_not_followed_from_far_from_its_start(navigator):
    site = Site(navigator)
    site.control.odometry.reset(site.pose().__class__(20.0, 11.0, 0.0))
    with pytest.raises(PlanningError, match="from where route dock-out starts"):
        FollowRoute(taught_route(), navigator, site.pose, tick=TICK)


def test_an_obstacle_on_a_taught_path_ends_the_route_with_the_reason(navigator):
    site = Site(navigator)
    site.site.surroundings.block(4.0, 10.9, size=1.9)  # across the corridor
    site.start(FollowRoute(taught_route(), navigator, site.pose, tick=TICK, limits=LIMITS,
                           sense=site.sense))  # fmt: skip
    site.run(120)
    assert site.ended and "blocked" in site.ended[0] and "no way round" in site.ended[0]
    assert site.true_pose().x < 4.0 - 0.95  # stopped short of it


def test_a_patrol_goes_to_rooms_and_follows_routes(navigator):
    site = Site(navigator)
    route = taught_route()
    patrol = Patrol("rounds", 1, False, [Stop("dock-out", 1.0, follow=True),
                                         Stop(None, 1.0, room="room-103")])  # fmt: skip
    reached = []

    def go(room):
        return GoTo(navigator, room, site.pose, tick=TICK, limits=LIMITS, sense=site.sense)

    def follow(taught):
        return FollowRoute(taught, navigator, site.pose, tick=TICK, limits=LIMITS,
                           sense=site.sense)  # fmt: skip

    run = site.start(PatrolRun(patrol, {"dock-out": route}, reached.append, go=go,
                               follow=follow))  # fmt: skip
    site.run(300)
    assert site.ended == ["done"]
    assert [stop.route_name for stop in reached] == ["dock-out", "room-103"]
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), PLAN.rooms["room-103"].at) <= 0.03
    assert run.finished
