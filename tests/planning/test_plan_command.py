"""`giraff-console plan` and `floorplan check` from the shell."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import networkx as nx

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.legs import GridLegs
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M, walls_of

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "giraff_console/floorplans/care-home.yaml"


def polyline_length(path: list[list[float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(path))


def optimal_route(plan_path: Path, origin: str, destination: str) -> tuple[float, list[str]]:
    """The shortest way by a graph built here from the file, and the doors on it: room
    points and open doors, doors of one room joined to each other and to its point,
    every leg measured on the grid beforehand (where the console measures only the legs
    a route may use)."""
    plan = load_floorplan(plan_path)
    legs = GridLegs(plan, walls_of(plan).inflated(ROBOT_RADIUS_M + CLEARANCE_M))
    graph = nx.Graph()

    def join(a, b, a_xy, b_xy, room):
        length = legs.length(a_xy, b_xy, room)
        if length is not None:
            graph.add_edge(a, b, weight=length)

    for door in plan.doors:
        if not door.open:
            continue
        for room in door.between:
            join(("room", room), ("door", door.id), plan.rooms[room].at, door.at, room)
            for other in plan.doors:
                if other.open and other is not door and room in other.between:
                    join(("door", door.id), ("door", other.id), door.at, other.at, room)
    length, nodes = nx.single_source_dijkstra(graph, ("room", origin), ("room", destination))
    return length, [node[1] for node in nodes if node[0] == "door"]


def test_plan_prints_an_optimal_route_as_json(capsys):
    assert main(["plan", "--floorplan", str(EXAMPLE), "dock", "activity-room", "--json"]) == 0
    route = json.loads(capsys.readouterr().out)
    assert set(route) == {"from", "to", "rooms", "doors", "length_m", "path"}
    assert route["rooms"] == ["dock", "corridor", "day-room", "activity-room"]
    assert route["doors"] == ["dock-corridor", "day-room-corridor", "activity-room-day-room"]
    assert math.isclose(route["length_m"], polyline_length(route["path"]), abs_tol=2e-3)
    # The optimal route; its path then crosses each door square on, which is a little
    # longer than the legs measured from door centre to door centre.
    best, doors = optimal_route(EXAMPLE, "dock", "activity-room")
    assert route["doors"] == doors
    assert best <= route["length_m"] <= best * 1.05
    assert route["path"][0] == [2.0, 7.0] and route["path"][-1] == [42.0, 16.0]


def test_the_planned_path_keeps_the_robot_off_the_walls(capsys):
    assert main(["plan", "--floorplan", str(EXAMPLE), "room-101", "kitchen", "--json"]) == 0
    route = json.loads(capsys.readouterr().out)
    plan = load_floorplan(EXAMPLE)
    legs = GridLegs(plan, walls_of(plan).inflated(ROBOT_RADIUS_M + CLEARANCE_M))
    assert all(legs.clear(a, b) for a, b in itertools.pairwise(route["path"]))
    # Longer than the straight lines through the doors: it goes round the door jambs.
    doors = {door.id: door.at for door in plan.doors}
    through = [doors[door_id] for door_id in route["doors"]]
    straight = polyline_length([plan.rooms["room-101"].at, *through, plan.rooms["kitchen"].at])
    assert straight < polyline_length(route["path"]) < straight * 1.1


def test_an_unknown_room_and_no_route_exit_non_zero_with_a_message(tmp_path, capsys):
    assert main(["plan", "--floorplan", str(EXAMPLE), "dock", "attic"]) == 2
    assert "no room called 'attic'" in capsys.readouterr().err
    # Two rooms whose only door is shut.
    shut = tmp_path / "shut.yaml"
    shut.write_text("name: shut\nrooms:\n  a: {at: [0, 0]}\n  b: {at: [2, 0]}\n"
                    "doors:\n  - {between: [a, b], at: [1, 0], open: false}\n")  # fmt: skip
    assert main(["plan", "--floorplan", str(shut), "a", "b"]) == 1
    assert "no route" in capsys.readouterr().err.lower()


def test_floorplan_check_lists_problems_and_exits_2(tmp_path, capsys):
    assert main(["floorplan", "check", str(EXAMPLE)]) == 0
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nrooms:\n  a: {at: [0, 0]}\ndoors:\n  - between: [a, b]\n"
                   "    at: [1, 0]\n")  # fmt: skip
    assert main(["floorplan", "check", str(bad)]) == 2
    out = capsys.readouterr().out
    assert f"{bad}:5:" in out and "b" in out


def test_floorplan_show_draws_the_rooms_walls_and_doors_within_the_width(capsys):
    assert main(["floorplan", "show", "--width", "100", str(EXAMPLE)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(len(line) for line in lines) <= 100
    drawing = "\n".join(lines)
    for label in ("dock", "corridor", "day-room", "dining-room", "101", "113"):
        assert label in drawing
    # The corridor's walls have gaps where the doors are.
    corridor = next(i for i, line in enumerate(lines) if "corridor" in line.replace("north-", ""))
    wall = lines[corridor - 1]
    assert wall.count("█") > 50 and "   " in wall.strip("░ ")


def test_floorplan_show_draws_outlines_when_there_is_no_grid(tmp_path, capsys):
    plan = tmp_path / "two.yaml"
    plan.write_text("name: two\nrooms:\n"
                    "  a: {at: [1, 1], outline: [[0, 0], [2, 0], [2, 2], [0, 2]]}\n"
                    "  b: {at: [3, 1], outline: [[2, 0], [4, 0], [4, 2], [2, 2]]}\n"
                    "doors:\n  - {between: [a, b], at: [2, 1]}\n")  # fmt: skip
    assert main(["floorplan", "show", "--width", "40", str(plan)]) == 0
    drawing = capsys.readouterr().out
    assert "a" in drawing and "b" in drawing and "█" in drawing
    assert main(["floorplan", "show", str(tmp_path / "none.yaml")]) == 2
    assert "cannot read" in capsys.readouterr().err
