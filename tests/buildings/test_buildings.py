"""The three test buildings of issue 25 (tests/buildings/) are plans the console takes as
they come: each passes `floorplan check`, has the rooms it was drawn with, and routes
between every pair of its rooms, as `plan A B` would. Driving them is the benchmark's
work (bench/any_building.py); these checks take seconds."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from giraff_console.planning.floorplan import FloorPlan, load_floorplan
from giraff_console.planning.route_planner import RoutePlanner, walls_of
from tests.buildings import BUILDINGS, put_up_markers
from tests.buildings.console import console
from tests.planning.test_rmf_buildings import off_free_cells

# Rooms and doors each comes out with: the clinic's 20 named vertices and its doors and
# passages; the home's 12 rooms drawn (until issue 29 its utility room came out split in
# two by the washing machines standing in it: furniture makes no rooms now); the wings'
# 39 rooms written.
ROOMS = {"rmf_clinic": 20, "scanned_home": 12, "walled_wing": 39}
DOORS = {"rmf_clinic": 21, "scanned_home": 12, "walled_wing": 39}


@pytest.fixture(scope="module", params=list(BUILDINGS))
def built(request, tmp_path_factory) -> tuple[str, Path]:
    """A building made in a folder of its own: its name and its plan's path."""
    folder = tmp_path_factory.mktemp(request.param)
    return request.param, BUILDINGS[request.param](folder)


def plan_of(built: tuple[str, Path]) -> FloorPlan:
    return load_floorplan(built[1])


def test_each_building_passes_floorplan_check(built):
    said = console("floorplan", "check", str(built[1]))
    assert said.code == 0 and "no problems" in said.out, said.out + said.err


def test_each_building_has_the_rooms_and_doors_it_was_drawn_with(built):
    name, _ = built
    plan = plan_of(built)
    assert (len(plan.rooms), len(plan.doors)) == (ROOMS[name], DOORS[name])
    assert plan.start is not None and plan.grid is not None


def test_the_buildings_are_the_three_ways_a_plan_comes(built):
    name, _ = built
    plan = plan_of(built)
    outlined = [room for room in plan.rooms.values() if room.outline]
    headed = [room for room in plan.rooms.values() if room.heading is not None]
    if name == "walled_wing":
        assert len(outlined) == len(plan.rooms) and 0 < len(headed) < len(plan.rooms)
    else:  # an import and a scan: points, doors and a grid, no outlines or headings
        assert outlined == [] and headed == []
    if name == "scanned_home":
        assert all(room.startswith("room-") for room in plan.rooms)


def test_narrow_doors_are_as_drawn(built):
    name, _ = built
    widths = [door.width for door in plan_of(built).doors]
    if name == "rmf_clinic":  # 0.9 to 1.0 m, and the double doors
        assert min(widths) == 0.9 and sum(w <= 1.0 for w in widths) >= 14
    else:  # house doors, and service rooms' doors, of 0.8 m
        assert sum(w <= 0.85 for w in widths) >= 5


def test_every_pair_of_rooms_routes_on_free_cells(built):
    plan = plan_of(built)
    grid = walls_of(plan)
    assert grid is not None
    planner = RoutePlanner(plan, grid)
    for a, b in itertools.combinations(sorted(plan.rooms), 2):
        planned = planner.between_rooms(a, b)
        assert planned.route.rooms[0] == a and planned.route.rooms[-1] == b
        assert off_free_cells(grid, planned.path) == [], (a, b)


def test_a_building_made_again_is_the_same(built, tmp_path):
    name, path = built
    again = BUILDINGS[name](tmp_path)
    assert again.read_bytes() == path.read_bytes()


def test_the_walled_wing_takes_markers_and_still_passes_the_checks(tmp_path):
    path = BUILDINGS["walled_wing"](tmp_path)
    markers = put_up_markers(path)
    assert markers.placed is not None and markers.placed > 2 * ROOMS["walled_wing"], markers
    assert len(load_floorplan(path).landmarks.markers) == markers.placed
    said = console("floorplan", "check", str(path))
    assert said.code == 0, said.out + said.err
