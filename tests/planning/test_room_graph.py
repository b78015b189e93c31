"""Routes through the room graph: which doors, how long, and doors closing under it."""

from __future__ import annotations

import math
import random
from pathlib import Path

import networkx as nx
import pytest

from giraff_console.planning.floorplan import Door, FloorPlan, Room, load_floorplan
from giraff_console.planning.room_graph import (
    NoRouteError,
    PlanningError,
    RoomGraph,
    UnknownDoorError,
    UnknownRoomError,
)

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.fixture
def home() -> RoomGraph:
    return RoomGraph(load_floorplan(FIXTURES / "small-home.yaml"))


def test_the_office_to_the_kitchen_goes_through_the_lounge_and_the_hall(home):
    # office (2,4) -> door (4,4) -> door (7,2) -> door (10,1) -> kitchen (12,3); the way
    # through the office's own door to the hall is 2 + sqrt(65) + sqrt(8) = 12.89 m.
    route = home.route("office", "kitchen")
    assert route.rooms == ["office", "lounge", "hall", "kitchen"]
    assert route.doors == ["office-lounge", "lounge-hall", "kitchen-hall"]
    assert route.path == [(2, 4), (4, 4), (7, 2), (10, 1), (12, 3)]
    assert route.length_m == pytest.approx(2 + math.sqrt(13) + math.sqrt(10) + math.sqrt(8))


def test_opening_a_closed_door_gives_a_shorter_route(home):
    home.open("kitchen-lounge")
    route = home.route("office", "kitchen")
    assert route.doors == ["office-lounge", "kitchen-lounge"]
    assert route.rooms == ["office", "lounge", "kitchen"]
    assert route.length_m == pytest.approx(2 + math.sqrt(37) + math.sqrt(8))


def test_closing_a_door_reroutes(home):
    home.close("office-lounge")
    route = home.route("office", "kitchen")
    assert route.rooms == ["office", "hall", "kitchen"]
    assert route.doors == ["office-hall", "kitchen-hall"]
    assert route.length_m == pytest.approx(2 + math.sqrt(65) + math.sqrt(8))


def test_closing_the_only_door_leaves_no_route(home):
    home.close("store-door")
    assert not home.is_open("store-door")
    with pytest.raises(NoRouteError, match="no route from 'hall' to 'store'"):
        home.route("hall", "store")
    home.open("store-door")
    assert home.route("hall", "store").doors == ["office-hall", "store-door"]


def test_a_route_to_where_the_robot_is_has_no_length(home):
    route = home.route("lounge", "lounge")
    assert (route.rooms, route.doors, route.length_m, route.path) == (
        ["lounge"],
        [],
        0.0,
        [(7, 4)],
    )


def test_an_unknown_room_is_a_planning_error(home):
    with pytest.raises(UnknownRoomError, match="no room called 'attic'") as caught:
        home.route("hall", "attic")
    assert isinstance(caught.value, PlanningError)


def test_an_unknown_door_is_a_planning_error_not_a_key_error(home):
    with pytest.raises(UnknownDoorError, match="no door called 'trapdoor'"):
        home.close("trapdoor")


def test_a_route_as_json(home):
    data = home.route("hall", "store").as_json()
    assert list(data) == ["from", "to", "rooms", "doors", "length_m", "path"]
    assert data["from"] == "hall" and data["to"] == "store"
    assert data["rooms"] == ["hall", "office", "store"]
    assert data["length_m"] == round(math.sqrt(10) + 5, 3)
    assert data["path"] == [[5, 1], [2, 2], [2, 6], [2, 7]]


def test_measured_legs_can_be_missing_or_longer_than_the_straight_line():
    plan = load_floorplan(FIXTURES / "small-home.yaml")
    asked = []

    def leg_length(a, b, room):
        asked.append(room)
        if {a, b} == {(4, 4), (7, 2)}:
            return None  # say the lounge is blocked between these doors
        return 2 * math.dist(a, b)

    route = RoomGraph(plan, leg_length).route("office", "kitchen")
    assert route.doors == ["office-hall", "kitchen-hall"]
    assert route.length_m == pytest.approx(2 * (2 + math.sqrt(65) + math.sqrt(8)))
    assert set(asked) <= set(plan.rooms)


def test_legs_are_measured_only_as_routes_need_them():
    plan = load_floorplan(FIXTURES / "small-home.yaml")
    asked = []

    def leg_length(a, b, room):
        asked.append((a, b))
        return math.dist(a, b)

    graph = RoomGraph(plan, leg_length)
    route = graph.route("office", "kitchen")
    # The straight lines are the lengths here, so the route is the one without a grid,
    # found by measuring only its own legs.
    assert route == RoomGraph(plan).route("office", "kitchen")
    assert len(asked) == len(route.path) - 1 < graph.graph.number_of_edges()
    graph.measure_all()
    assert len(asked) == graph.graph.number_of_edges()
    assert graph.route("office", "kitchen") == route


def test_a_route_from_a_point_starts_there_and_takes_the_nearer_door():
    graph = RoomGraph(load_floorplan(FIXTURES / "small-home.yaml"))
    # In the office next to its door to the lounge (4, 4): through it, not via the
    # office's point (2, 4).
    route = graph.route_from((3.8, 4.5), "office", "kitchen")
    assert route.rooms == ["office", "lounge", "hall", "kitchen"]
    assert route.path[0] == (3.8, 4.5) and route.path[1] == (4, 4)
    assert route.length_m == pytest.approx(
        math.dist((3.8, 4.5), (4, 4)) + math.sqrt(13) + math.sqrt(10) + math.sqrt(8)
    )
    assert ("robot", "") not in graph.graph


def random_plan(seed: int) -> FloorPlan:
    """Rooms on a 4 x 3 lattice with random points and a random set of doors."""
    rng = random.Random(seed)
    rooms = {
        f"r{i}{j}": Room(f"r{i}{j}", "", (i * 4 + rng.uniform(0.5, 3.5), j * 4 + rng.random()),
                         None, None)
        for i in range(4)
        for j in range(3)
    }  # fmt: skip
    doors = []
    for i in range(4):
        for j in range(3):
            for di, dj in ((1, 0), (0, 1)):
                if i + di < 4 and j + dj < 3 and rng.random() < 0.7:
                    at = (i * 4 + 4 * di + rng.random() * 4 * dj, j * 4 + 4 * dj + rng.random())
                    between = (f"r{i}{j}", f"r{i + di}{j + dj}")
                    doors.append(Door("-".join(between), between, at, 0.9, rng.random() < 0.8))
    return FloorPlan("random", rooms, doors, None, None, Path("random.yaml"))


@pytest.mark.parametrize("seed", range(20))
def test_routes_are_the_optimum_astar_finds(seed):
    graph = RoomGraph(random_plan(seed))
    g = graph.graph

    def heuristic(a, b):
        return math.dist(g.nodes[a]["xy"], g.nodes[b]["xy"])

    for a in graph.plan.rooms:
        for b in graph.plan.rooms:
            try:
                best = nx.astar_path_length(g, ("room", a), ("room", b), heuristic, "weight")
            except nx.NetworkXNoPath:
                with pytest.raises(NoRouteError):
                    graph.route(a, b)
                continue
            route = graph.route(a, b)
            assert route.length_m == pytest.approx(best)
            assert sum(map(math.dist, route.path, route.path[1:])) == pytest.approx(best)
            assert route.rooms[0] == a and route.rooms[-1] == b
            assert len(route.rooms) == len(route.doors) + 1
            for door, here, there in zip(route.doors, route.rooms, route.rooms[1:], strict=False):
                assert set(graph.doors[door].between) == {here, there}
                assert graph.is_open(door)


def test_changing_a_route_does_not_change_the_next_one(home):
    home.route("hall", "store").doors.clear()
    assert home.route("hall", "store").doors == ["office-hall", "store-door"]
