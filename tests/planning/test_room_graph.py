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
EXAMPLE = Path(__file__).parents[2] / "giraff_console/floorplans/care-home.yaml"


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


def all_pairs_lengths(plan: FloorPlan, leg_length=None, closed=()) -> dict:
    """The former planner's answers: every leg of every open door in an undirected
    networkx graph of room and door nodes, and Dijkstra from every room."""
    graph = nx.Graph()
    for room in plan.rooms.values():
        graph.add_node(("room", room.id))
    doors_of: dict[str, list] = {room: [] for room in plan.rooms}

    def join(a, b, at_a, at_b, room):
        length = math.dist(at_a, at_b) if leg_length is None else leg_length(at_a, at_b, room)
        if length is not None:
            graph.add_edge(a, b, weight=length)

    for door in plan.doors:
        if door.id in closed or not door.open:
            continue
        for room_id in door.between:
            join(("door", door.id), ("room", room_id), door.at, plan.rooms[room_id].at, room_id)
            for other in doors_of[room_id]:
                join(("door", door.id), ("door", other.id), door.at, other.at, room_id)
            doors_of[room_id].append(door)
    return {a: nx.single_source_dijkstra_path_length(graph, ("room", a)) for a in plan.rooms}


def assert_routes_are(graph: RoomGraph, expected: dict) -> None:
    for a in graph.plan.rooms:
        for b in graph.plan.rooms:
            best = expected[a].get(("room", b))
            if best is None:
                with pytest.raises(NoRouteError):
                    graph.route(a, b)
                continue
            route = graph.route(a, b)
            assert route.length_m == pytest.approx(best)
            assert route.rooms[0] == a and route.rooms[-1] == b
            for door, here, there in zip(route.doors, route.rooms, route.rooms[1:], strict=False):
                assert set(graph.doors[door].between) == {here, there}
                assert graph.is_open(door)


def with_doors_open(plan: FloorPlan) -> FloorPlan:
    doors = [Door(d.id, d.between, d.at, d.width, True) for d in plan.doors]
    return FloorPlan(plan.name, plan.rooms, doors, None, None, plan.path)


def test_lazy_routes_are_the_former_all_pairs_answers_on_the_example():
    plan = with_doors_open(load_floorplan(EXAMPLE))
    assert_routes_are(RoomGraph(plan), all_pairs_lengths(plan))


@pytest.mark.parametrize("seed", range(20))
def test_lazy_routes_with_measured_legs_are_the_former_all_pairs_answers(seed):
    # Each room stretches its legs by its own factor, as a room full of furniture does;
    # within a room the lengths still obey the triangle inequality, as ways do.
    plan = with_doors_open(random_plan(seed))
    stretch = {room: 1 + random.Random(f"{seed}{room}").random() for room in plan.rooms}
    asked = []

    def leg_length(a, b, room):
        asked.append((a, b, room))
        return math.dist(a, b) * stretch[room]

    graph = RoomGraph(plan, leg_length)
    assert_routes_are(graph, all_pairs_lengths(plan, leg_length))
    assert len(set(asked)) == len(asked)  # no leg measured twice


@pytest.mark.parametrize("seed", range(10))
def test_door_events_give_the_former_answers_for_the_doors_then_open(seed):
    plan = with_doors_open(random_plan(seed))
    graph = RoomGraph(plan)
    rng = random.Random(seed)
    closed: set[str] = set()
    for _ in range(6):
        door = rng.choice(plan.doors).id
        if door in closed:
            graph.open(door)
            closed.discard(door)
        else:
            graph.close(door)
            closed.add(door)
        assert_routes_are(graph, all_pairs_lengths(plan, closed=tuple(closed)))


def test_a_door_event_measures_nothing_and_a_route_is_kept_until_one():
    plan = load_floorplan(FIXTURES / "small-home.yaml")
    asked = []

    def leg_length(a, b, room):
        asked.append((a, b))
        return math.dist(a, b)

    graph = RoomGraph(plan, leg_length)
    first = graph.route("office", "kitchen")
    measured = len(asked)
    assert graph.route("office", "kitchen") == first and len(asked) == measured
    graph.close("office-lounge")
    assert len(asked) == measured
    rerouted = graph.route("office", "kitchen")
    assert "office-lounge" not in rerouted.doors
    graph.open("office-lounge")
    assert graph.route("office", "kitchen") == first


def test_a_route_never_touches_a_door_and_turns_back():
    # Three doors on one line along the hall: through the middle one is as short as
    # straight on by the straight lines, and must not be taken, nor measured.
    rooms = {
        "hall": Room("hall", "", (0, 0), None, None),
        **{name: Room(name, "", (x, 2), None, None) for name, x in (("a", 0), ("b", 5), ("c", 10))},
    }
    doors = [Door(f"{name}-door", ("hall", name), (x, 1), 0.9, True)
             for name, x in (("a", 0), ("b", 5), ("c", 10))]  # fmt: skip
    plan = FloorPlan("hall", rooms, doors, None, None, Path("hall.yaml"))
    asked = []

    def leg_length(a, b, room):
        asked.append({a, b})
        return math.dist(a, b) + 0.5  # out of one doorway and into the next

    route = RoomGraph(plan, leg_length).route("a", "c")
    assert route.doors == ["a-door", "c-door"]
    assert route.path == [(0, 2), (0, 1), (10, 1), (10, 2)]
    assert len(asked) == 3 and all((5, 1) not in leg for leg in asked)


def test_a_door_at_its_rooms_point_is_a_leg_of_no_length():
    rooms = {"a": Room("a", "", (0, 0), None, None), "b": Room("b", "", (3, 0), None, None)}
    plan = FloorPlan("two", rooms, [Door("d", ("a", "b"), (0, 0), 0.9, True)], None, None,
                     Path("two.yaml"))  # fmt: skip
    route = RoomGraph(plan).route("a", "b")
    assert route.doors == ["d"] and route.length_m == pytest.approx(3)


def test_a_route_from_a_point_is_the_former_answer_from_there():
    plan = load_floorplan(FIXTURES / "small-home.yaml")
    graph = RoomGraph(plan)
    nodes = graph.graph
    for point, room in (((3.8, 4.5), "office"), ((8, 2.5), "hall"), ((12.5, 3.5), "kitchen")):
        nodes.add_edge("robot", ("room", room), weight=math.dist(point, plan.rooms[room].at))
        for door in plan.doors:
            if room in door.between and door.open:
                nodes.add_edge("robot", ("door", door.id), weight=math.dist(point, door.at))
        lengths = nx.single_source_dijkstra_path_length(nodes, "robot")
        nodes.remove_node("robot")
        for to_room in plan.rooms:
            if ("room", to_room) not in lengths:
                with pytest.raises(NoRouteError):
                    graph.route_from(point, room, to_room)
                continue
            route = graph.route_from(point, room, to_room)
            assert route.length_m == pytest.approx(lengths[("room", to_room)])
            assert route.path[0] == point and route.rooms[0] == room
