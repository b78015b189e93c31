"""Real traffic-editor maps imported as they are (issue 16): several fleets' lanes through
shared doors, a door before a junction, repeated names, a door named like a room,
corridors with no names, walls, floors and two levels (tests/planning/rmf_buildings.py)."""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import math
import multiprocessing
import os
import re
import subprocess
import sys
import time
import tracemalloc
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.planning.rmf_import import read_building
from giraff_console.planning.route_planner import RoutePlanner, walls_of
from tests.planning.rmf_buildings import (
    HEIGHT_M,
    Level,
    gap_only,
    junction_by_door,
    one_level,
    open_hall,
    stray_vertex,
    write_building,
)

# Ten rooms of L1 for `go`: through the corridor door and the rooms' doors, passages in
# the lobby and the rooms, the corridors' room of its own, round by the dining room.
GOALS = ["waiting_area-2", "office_1", "coffee_machine", "store_room", "space-1", "gym",
         "dining_table_2", "nurse_station", "lab_bench", "reading_corner"]  # fmt: skip
NOTE = re.compile(r"^giraff-console: \S+\.building\.yaml:\d+: note: ")


def imported(tmp_path: Path, capsys, *options: str, **building: object) -> tuple[Path, str]:
    """The office building written and imported with the CLI as a user runs it: the
    floor plan written, and what the command printed to standard error."""
    source = write_building(tmp_path, **building)
    out = tmp_path / "out.yaml"
    assert main(["floorplan", "import", str(source), str(out), *options]) == 0
    return out, capsys.readouterr().err


@pytest.fixture(scope="module")
def office(tmp_path_factory) -> Path:
    """Level L1 of the office building, imported once for the tests that only read it."""
    folder = tmp_path_factory.mktemp("office")
    out = folder / "office.yaml"
    assert main(["floorplan", "import", str(write_building(folder)), str(out), "--level",
                 "L1"]) == 0  # fmt: skip
    return out


def door_ids(plan: dict) -> set[str]:
    return {door["id"] for door in plan["doors"]}


def between(plan: dict, door_id: str) -> set[str]:
    (door,) = [door for door in plan["doors"] if door["id"] == door_id]
    return set(door["between"])


def design(x: float, y: float) -> tuple[float, float]:
    """A point of rmf_buildings' design in the map frame."""
    return (x, y - HEIGHT_M)


def design_of(point: list[float]) -> tuple[float, float]:
    """A point of the map frame in rmf_buildings' design."""
    return (point[0], point[1] + HEIGHT_M)


def test_the_office_imports_in_one_command_with_its_grid_next_to_it(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1")
    plan = load_floorplan(out)
    assert len(plan.rooms) == 28 and len(plan.doors) == 33
    assert plan.grid is not None and plan.grid.image == tmp_path / "out.pgm"
    assert plan.start == "tinyRobot1_charger"
    assert all(NOTE.match(line) for line in err.splitlines()), err


def test_every_pair_of_rooms_has_a_route_on_the_drawn_grid(office):
    plan = load_floorplan(office)
    grid = walls_of(plan)
    planner = RoutePlanner(plan, grid)
    pairs = list(itertools.combinations(sorted(plan.rooms), 2))
    assert len(pairs) == 378
    assert grid is not None
    for a, b in pairs:
        planned = planner.between_rooms(a, b)
        assert planned.route.rooms[0] == a and planned.route.rooms[-1] == b
        assert off_free_cells(grid, planned.path) == [], (a, b)


def off_free_cells(grid: OccupancyGrid, path: list[tuple[float, float]]) -> list:
    """The points of `path`, sampled every centimetre, that are not on a free cell of
    `grid`."""
    points = np.array(path, float)
    samples = [points[-1:]]
    for start, end in itertools.pairwise(points):
        steps = max(1, math.ceil(math.dist(start, end) / 0.01))
        samples.append(start + np.outer(np.arange(steps) / steps, end - start))
    xy = np.concatenate(samples)
    rows = grid.shape[0] - 1 - np.floor((xy[:, 1] - grid.origin[1]) / grid.resolution)
    cols = np.floor((xy[:, 0] - grid.origin[0]) / grid.resolution)
    inside = (rows >= 0) & (rows < grid.shape[0]) & (cols >= 0) & (cols < grid.shape[1])
    free = np.zeros(len(xy), bool)
    free[inside] = grid.cells[rows[inside].astype(int), cols[inside].astype(int)] == FREE
    return xy[~free].round(2).tolist()


# Seconds for the ten drives on a loaded 2-core machine.
GO_TIMEOUT_S = 240


def go_json(floorplan: Path, room: str) -> tuple[int, str, str]:
    """`go ROOM --json` in the simulator as fast as it runs: the exit code, standard output
    and standard error."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["go", room, "--sim", "--floorplan", str(floorplan), "--sim-speed", "inf",
                     "--json"])  # fmt: skip
    return code, out.getvalue(), err.getvalue()


def test_go_reaches_ten_rooms_in_the_simulator_within_3_cm(office):
    # Each drive is a second or two of the simulator's own work: the ten rooms are driven
    # side by side on every core. Spawned, not forked: a fork of a process with threads
    # (earlier tests' loops) can inherit a lock held by one of them and hang.
    workers = min(len(GOALS), os.cpu_count() or 1)
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        drives = pool.map(go_json, [office] * len(GOALS), GOALS, timeout=GO_TIMEOUT_S)
        done = dict(zip(GOALS, drives, strict=True))
    errors = {}
    for room, (code, out, err) in done.items():
        # No markers on the imported plan: arrived by the odometry, unconfirmed (exit 3).
        assert code == 3, err
        report = json.loads(out)
        assert report["outcome"] == "arrived_unverified" and report["why"] == "done", report
        errors[room] = report["error_m"]
    assert max(errors.values()) <= 0.03, errors


def test_parallel_lanes_of_three_fleets_through_one_door_make_one_door(office):
    plan = yaml.safe_load(office.read_text())
    # The nearest rooms either side: fleet 2's waiting area in the lobby, the corridor's end.
    assert between(plan, "corridor_door") == {"waiting_area-2", "corridor_east"}
    # The pantry's door has lanes of fleets 0, 1 and 2 through it: still one door.
    assert between(plan, "pantry-door") == {"corridor_east", "pantry"}
    (door,) = [door for door in plan["doors"] if door["id"] == "corridor_door"]
    assert door["at"] == pytest.approx(design(12.0, 8.0)) and door["width"] == 2.0


def test_a_corridor_with_no_named_vertex_is_a_room_of_its_own(office):
    plan = yaml.safe_load(office.read_text())
    # The north and back corridors: the north door (before the lanes' junction in the
    # main corridor), the office's back door, and the gym's, library's, chapel's lead there.
    for door_id in ["north_door", "office_2_back_door", "gym_door", "library_door",
                    "chapel_door"]:  # fmt: skip
        assert "space-1" in between(plan, door_id)
    x, y = design_of(plan["rooms"]["space-1"]["at"])
    in_back_corridor = 15 < x < 42 and 14 < y < 16
    in_north_corridor = 12 < x < 15 and 9.2 < y < 16
    assert in_back_corridor or in_north_corridor, (x, y)


def test_repeated_vertex_names_are_numbered_with_a_note_at_the_second(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1")
    rooms = yaml.safe_load(out.read_text())["rooms"]
    assert rooms["waiting_area"]["at"] == pytest.approx(design(9.5, 4.0))
    assert rooms["waiting_area-2"]["label"] == "waiting_area"
    assert rooms["waiting_area-2"]["at"] == pytest.approx(design(9.5, 5.4))
    source = (tmp_path / "office.building.yaml").read_text().splitlines()
    first, second = [i for i, text in enumerate(source, 1) if text.endswith(" waiting_area]")]
    assert f"office.building.yaml:{second}: note: vertex 7 ('waiting_area') would be room " \
           f"'waiting_area', as vertex 6 ('waiting_area', line {first}) is: it is room " \
           "'waiting_area-2'" in err  # fmt: skip


def test_a_door_named_like_a_room_is_renamed_with_a_note(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1")
    plan = yaml.safe_load(out.read_text())
    assert "pantry" in plan["rooms"] and "pantry-door" in door_ids(plan)
    assert "note: door 'pantry' has the name of a room: it is door 'pantry-door'" in err


def test_doors_to_outside_are_left_out_and_shut_in_the_grid(office):
    plan = load_floorplan(office)
    assert not {"main_entrance", "garden_door"} & {door.id for door in plan.doors}
    grid = walls_of(plan)
    assert grid is not None
    # The entrance's doorway in the west wall stays wall; the corridor door is open.
    assert grid.cells[grid.cell_of(*design(2.0, 3.8))] == OCCUPIED
    assert grid.cells[grid.cell_of(*design(12.0, 8.0))] == FREE


def test_the_drawn_grid_has_the_walls_the_floor_and_the_hole(office):
    plan = load_floorplan(office)
    grid = walls_of(plan)
    assert isinstance(grid, OccupancyGrid) and grid.resolution == 0.05
    cell = grid.cell_of
    assert grid.cells[cell(*design(18.0, 4.0))] == OCCUPIED  # between office_1 and the pantry
    assert grid.cells[cell(*design(15.0, 6.8))] == FREE  # office_1's door, open
    assert grid.cells[cell(*design(10.5, 12.0))] == UNKNOWN  # the stairwell: a hole
    assert grid.cells[cell(*design(1.8, 12.0))] == UNKNOWN  # outside the floor
    assert grid.cells[cell(*design(7.0, 8.0))] == FREE
    image = cv2.imread(str(plan.grid.image), cv2.IMREAD_UNCHANGED)
    assert image.shape == grid.cells.shape


def test_a_charger_against_a_wall_is_moved_clear_of_it_and_is_the_start(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1")
    plan = load_floorplan(out)
    x, y = plan.rooms["tinyRobot1_charger"].at
    assert x - 2.05 >= 0.45 - 0.06 and math.dist((x, y), design(2.35, 7.0)) < 0.3
    assert plan.start == "tinyRobot1_charger"
    assert "note: vertex 0 ('tinyRobot1_charger') is 0.25 m from a wall: room" in err


def test_reference_image_and_cartesian_metres_import_alike(tmp_path):
    pixels = read_building(write_building(tmp_path, "pixels"), "L1").plan
    metres = read_building(write_building(tmp_path, "metres", system="cartesian_meters"),
                           "L1").plan  # fmt: skip
    assert pixels["rooms"] == metres["rooms"]
    assert pixels["doors"] == metres["doors"]


def test_a_level_without_walls_is_found_from_its_lanes_and_routes_every_pair(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1", walls=False)
    plan = load_floorplan(out)
    assert plan.grid is None and not (tmp_path / "out.pgm").exists()
    assert len(plan.rooms) == 28
    raw = yaml.safe_load(out.read_text())
    # Three fleets' lanes through the corridor door, which is before a junction: one door.
    assert between(raw, "corridor_door") == {"waiting_area-2", "corridor_east"}
    assert "space-1" in between(raw, "north_door")
    assert "note: door 'main_entrance' crosses no lane: left out" in err
    planner = RoutePlanner(plan)
    for a, b in itertools.combinations(sorted(plan.rooms), 2):
        assert planner.between_rooms(a, b).route.rooms[-1] == b


def test_a_second_level_imports_on_its_own(tmp_path, capsys):
    out, _ = imported(tmp_path, capsys, "--level", "L2")
    plan = load_floorplan(out)
    assert set(plan.rooms) == {"ward_a", "ward_b", "ward_c", "ward_d", "day_room", "therapy",
                               "office_3", "linen", "space-1"}  # fmt: skip
    assert len(plan.doors) == 8


def test_a_map_of_several_levels_needs_one_chosen_and_nothing_is_written(tmp_path, capsys):
    source = write_building(tmp_path)
    assert main(["floorplan", "import", str(source), str(tmp_path / "out.yaml")]) == 2
    assert f"{source}:5: several levels (L1, L2): choose one (--level)" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == [source]


def test_graph_takes_one_fleets_lanes_and_places(tmp_path, capsys):
    out, err = imported(tmp_path, capsys, "--level", "L1", "--graph", "1")
    rooms = load_floorplan(out).rooms
    # Fleet 1's: its charger, its waiting area and the places its lanes reach.
    assert {"deliveryRobot1_charger", "waiting_area", "coffee_machine", "projector",
            "lab_bench"} <= set(rooms)  # fmt: skip
    assert not {"tinyRobot1_charger", "waiting_area-2", "office_1", "pantry"} & set(rooms)
    # Each place of the other fleets, told at its line.
    source = (tmp_path / "office.building.yaml").read_text().splitlines()
    line = next(i for i, text in enumerate(source, 1) if " tinyRobot1_charger, " in text)
    assert f"office.building.yaml:{line}: note: vertex 0 ('tinyRobot1_charger') is only on " \
           "lanes of other graphs than the one chosen (--graph): left out" in err  # fmt: skip


def test_a_graph_with_no_lanes_is_an_error_naming_the_graphs(tmp_path, capsys):
    source = write_building(tmp_path)
    args = ["floorplan", "import", str(source), str(tmp_path / "out.yaml"), "--level", "L1"]
    assert main([*args, "--graph", "7"]) == 2
    assert "levels.L1 has no lanes in graph 7 (it has graphs 0, 1, 2)" in capsys.readouterr().err


def test_bad_input_is_every_problem_at_its_line_and_nothing_is_written(tmp_path, capsys):
    text = write_building(tmp_path).read_text()
    lines = text.splitlines()
    first_wall = next(i for i, line in enumerate(lines) if line == "    walls:") + 1
    lines[first_wall] = "      - [0, 9999, {alpha: [3, 1]}]"
    first_lane = next(i for i, line in enumerate(lines) if line == "    lanes:") + 1
    lines[first_lane] = "      - [0, 1, {graph_idx: [2, fleet]}]"
    source = tmp_path / "bad.building.yaml"
    source.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.yaml"
    assert main(["floorplan", "import", str(source), str(out), "--level", "L1"]) == 2
    err = capsys.readouterr().err
    wall = f"{source}:{first_wall + 1}: levels.L1.walls[0] should be [v1, v2, {{parameters}}]"
    assert wall in err
    assert f"{source}:{first_lane + 1}: levels.L1.lanes[0]'s graph_idx should be [2, n]" in err
    assert not out.exists() and not out.with_suffix(".pgm").exists()


def test_the_grid_image_is_not_overwritten_without_force(tmp_path, capsys):
    source = write_building(tmp_path)
    (tmp_path / "out.pgm").write_text("mine")
    args = ["floorplan", "import", str(source), str(tmp_path / "out.yaml"), "--level", "L1"]
    assert main(args) == 2
    assert f"{tmp_path / 'out.pgm'} exists: --force overwrites it" in capsys.readouterr().err
    assert (tmp_path / "out.pgm").read_text() == "mine" and not (tmp_path / "out.yaml").exists()
    assert main([*args, "--force"]) == 0
    assert load_floorplan(tmp_path / "out.yaml").grid is not None


def test_force_never_writes_over_the_source_or_the_ros_map(tmp_path, capsys):
    source = write_building(tmp_path)
    kept = source.read_bytes()
    args = ["floorplan", "import", str(source), str(source), "--level", "L1", "--force"]
    assert main(args) == 2
    assert f"OUT {source} would overwrite SOURCE {source}" in capsys.readouterr().err
    assert source.read_bytes() == kept
    # A ROS map as --grid, and OUT given its name by mistake.
    image = np.full((600, 900), 254, dtype=np.uint8)
    assert cv2.imwrite(str(tmp_path / "a.pgm"), image)
    ros = tmp_path / "scan.yaml"
    ros.write_text("image: a.pgm\nresolution: 0.05\norigin: [-2.0, -28.0, 0.0]\nnegate: 0\n"
                   "occupied_thresh: 0.65\nfree_thresh: 0.196\n")  # fmt: skip
    map_text = ros.read_text()
    args = ["floorplan", "import", str(source), str(ros), "--level", "L1", "--grid", str(ros),
            "--force"]  # fmt: skip
    assert main(args) == 2
    assert f"OUT {ros} would overwrite MAP {ros}" in capsys.readouterr().err
    assert ros.read_text() == map_text and not (tmp_path / "scan.pgm").exists()


def test_python_m_giraff_console_imports_from_another_folder(tmp_path):
    source = write_building(tmp_path)
    work = tmp_path / "elsewhere"
    work.mkdir()
    command = [sys.executable, "-m", "giraff_console", "floorplan", "import", str(source),
               "plan.yaml", "--level", "L1"]  # fmt: skip
    done = subprocess.run(command, cwd=work, capture_output=True, text=True, timeout=120,
                          env=os.environ | {"CI": "true"}, stdin=subprocess.DEVNULL)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("wrote plan.yaml: 28 rooms (")
    assert "wrote plan.pgm: the grid, drawn from the level's walls and doors" in done.stdout
    assert load_floorplan(work / "plan.yaml").grid.image == work / "plan.pgm"


WALLED_OFF = """\
coordinate_system: cartesian_meters
levels:
  L1:
    vertices:
      - [0, 0, 0, ""]
      - [10, 0, 0, ""]
      - [10, 4, 0, ""]
      - [0, 4, 0, ""]
      - [5, 0, 0, ""]
      - [5, 4, 0, ""]
      - [2, 2, 0, west]
      - [8, 2, 0, east]
      - [3.5, 2, 0, west_desk]
    walls: [[0, 1, {}], [1, 2, {}], [2, 3, {}], [3, 0, {}], [4, 5, {}]]
    lanes:
      - [6, 7, {graph_idx: [2, 0]}]
      - [6, 8, {graph_idx: [2, 0]}]
"""


def test_a_room_walled_off_with_no_door_is_left_out_and_the_lane_to_it_noted(tmp_path, capsys):
    # Two rooms with a wall between them and no door: a lane through the wall is not a way.
    source = tmp_path / "walled.building.yaml"
    source.write_text(WALLED_OFF)
    out = tmp_path / "walled.yaml"
    assert main(["floorplan", "import", str(source), str(out)]) == 0
    err = capsys.readouterr().err
    assert f"{source}:12: note: vertex 7 ('east') is cut off from the rest of the level" in err
    assert f"{source}:16: note: the lane from vertex 6 to vertex 7 runs through a wall" in err
    plan = load_floorplan(out)
    assert list(plan.rooms) == ["west", "west_desk"]
    assert [door.id for door in plan.doors] == ["west-west_desk"]
    # No floor polygons: the floor is what the walls close in; round them is outside.
    grid = walls_of(plan)
    assert grid is not None
    assert grid.cells[grid.cell_of(-0.3, 2.0)] == UNKNOWN
    assert grid.cells[grid.cell_of(2.0, 3.0)] == FREE
    assert grid.cells[grid.cell_of(5.0, 2.0)] == OCCUPIED


def import_shape(tmp_path: Path, capsys, level: Level) -> tuple[Path, Path, str]:
    """One of rmf_buildings' shapes written and imported: the map, the floor plan written
    and what the command printed to standard error."""
    source = tmp_path / "shape.building.yaml"
    source.write_text(one_level(level))
    out = tmp_path / "shape.yaml"
    assert main(["floorplan", "import", str(source), str(out)]) == 0
    return source, out, capsys.readouterr().err


def line_of(source: Path, text: str) -> int:
    (line,) = [i for i, line in enumerate(source.read_text().splitlines(), 1) if text in line]
    return line


@pytest.mark.parametrize("gap", [0.15, 0.3, 0.5])
def test_a_gap_too_narrow_for_the_robot_joins_no_rooms(tmp_path, capsys, gap):
    source, out, err = import_shape(tmp_path, capsys, gap_only(gap))
    plan = load_floorplan(out)
    assert list(plan.rooms) == ["west_room"] and not plan.doors
    line = line_of(source, " east_room]")
    assert f"{source}:{line}: note: vertex 1 ('east_room') is cut off from the rest of the " \
           "level" in err  # fmt: skip


def test_a_gap_the_robot_can_pass_is_a_passage_it_plans_through(tmp_path, capsys):
    _, out, _ = import_shape(tmp_path, capsys, gap_only(0.8))
    plan = load_floorplan(out)
    assert list(plan.rooms) == ["west_room", "east_room"]
    grid = walls_of(plan)
    assert grid is not None
    planned = RoutePlanner(plan, grid).between_rooms("west_room", "east_room")
    assert planned.route.rooms == ["west_room", "east_room"]
    assert off_free_cells(grid, planned.path) == []


def test_a_stray_named_vertex_far_off_is_noted_and_changes_nothing_else(tmp_path, capsys):
    source, out, err = import_shape(tmp_path, capsys, stray_vertex())
    plan = load_floorplan(out)
    assert len(plan.rooms) == 9 and len(plan.doors) == 8
    assert walls_of(plan).resolution == 0.05
    line = line_of(source, " old_marker]")
    assert f"{source}:{line}: note: vertex " in err and "('old_marker') is off the level's " \
           "floor, more than 1 m from it: left out" in err  # fmt: skip
    assert err.count("off the level's floor") == 1, err


@pytest.mark.parametrize("past", [0.001, -0.001, 0.0, 0.009])
def test_a_junction_within_a_centimetre_of_a_door_is_in_its_doorway(tmp_path, capsys, past):
    _, out, err = import_shape(tmp_path, capsys, junction_by_door(past))
    plan = yaml.safe_load(out.read_text())
    assert list(plan["rooms"]) == ["hall", "hall_chair", "bed_1", "bed_2"], err
    (door,) = [door for door in plan["doors"] if door["id"] == "bedroom_door"]
    assert door["between"][0] == "hall" and door["between"][1] in {"bed_1", "bed_2"}
    assert "note:" not in err


def test_an_open_hall_of_many_places_is_one_search_not_one_a_place(tmp_path):
    # 200 named places in a 60 m by 40 m hall: a search from each kept 200 x 240,000
    # distances and as many ways back (over 550 MB); one search from all of them, one.
    source = tmp_path / "hall.building.yaml"
    source.write_text(one_level(open_hall(200)))
    tracemalloc.start()
    began = time.perf_counter()
    made = read_building(source)
    took = time.perf_counter() - began
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert len(made.plan["rooms"]) == 200 and len(made.plan["doors"]) == 199
    assert peak < 300e6, peak
    assert took < 20, took
