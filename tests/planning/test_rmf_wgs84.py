"""Geo-referenced Open-RMF buildings (`coordinate_system: wgs84`, issue 29 item 5): the
clinic of tests/buildings/ written in longitude and latitude about Stockholm imports in
metres, plans and drives as it does drawn in pixels; bad numbers are told at their
lines."""

from __future__ import annotations

import json
import math
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest
import yaml

from giraff_console.planning.rmf_wgs84 import EXTENT_M, TangentPlane
from tests.buildings.console import console
from tests.buildings.rmf_clinic import clinic_level
from tests.buildings.rmf_clinic_wgs84 import (
    STOCKHOLM,
    clinic_pixels_text,
    clinic_wgs84_text,
    middle,
    placing,
    rmf_clinic_wgs84,
)
from tests.planning.rmf_buildings import HEIGHT_M, level_one, level_two
from tests.planning.test_rmf_buildings import GO_TIMEOUT_S, go_json

MM = 0.001
# WGS 84's ellipsoid, for the meridian's and the parallel's lengths worked out here
# without the importer's earth-centred frame.
A_M, F = 6378137.0, 1 / 298.257223563
E2 = F * (2 - F)


@pytest.fixture(scope="module")
def geo(tmp_path_factory) -> Path:
    """The wgs84 clinic, imported with the console."""
    return rmf_clinic_wgs84(tmp_path_factory.mktemp("wgs84"))


@pytest.fixture(scope="module")
def pixels(tmp_path_factory) -> Path:
    """The same clinic drawn in pixels (reference_image), imported with the console."""
    folder = tmp_path_factory.mktemp("pixels")
    source = folder / "clinic.building.yaml"
    source.write_text(clinic_pixels_text())
    out = folder / "clinic.yaml"
    said = console("floorplan", "import", str(source), str(out))
    assert said.code == 0, said.err
    return out


def meridian_arc(lat1: float, lat2: float) -> float:
    """Metres along a meridian from `lat1` to `lat2` (degrees): Simpson's rule over the
    meridian's radius of curvature."""
    steps = 200
    h = math.radians(lat2 - lat1) / steps

    def radius(k: int) -> float:
        s = math.sin(math.radians(lat1) + k * h)
        return A_M * (1 - E2) / (1 - E2 * s * s) ** 1.5

    weights = [1 if k in (0, steps) else 4 if k % 2 else 2 for k in range(steps + 1)]
    return h / 3 * sum(w * radius(k) for k, w in enumerate(weights))


def test_the_tangent_plane_measures_the_ground_to_a_micrometre():
    lon, lat = STOCKHOLM
    plane = TangentPlane(lon, lat)
    # 100 m along the meridian through the origin: the ground's length there.
    half = 50 / 111_000
    north = plane.metres(lon, lat + half)[1] - plane.metres(lon, lat - half)[1]
    assert abs(north - meridian_arc(lat - half, lat + half)) < 1e-6
    # And along the parallel: its radius is the prime vertical's times cos(latitude).
    across = A_M / math.sqrt(1 - E2 * math.sin(math.radians(lat)) ** 2)
    half_lon = 50 / 56_800
    east = plane.metres(lon + half_lon, lat)[0] - plane.metres(lon - half_lon, lat)[0]
    parallel = across * math.cos(math.radians(lat)) * math.radians(2 * half_lon)
    assert abs(east - parallel) < 1e-6
    assert plane.metres(lon, lat) == (0.0, 0.0)


def test_the_wgs84_clinic_has_its_rooms_where_they_were_drawn_within_a_millimetre(geo):
    plan = yaml.safe_load(geo.read_text())
    mx, my = clinic_wgs84_text()[1]
    drawn = {name: (x - mx, y - my) for x, y, name, _ in clinic_level().vertices if name}
    assert set(plan["rooms"]) == set(drawn) and len(drawn) == 20
    for room, place in plan["rooms"].items():
        assert math.dist(place["at"], drawn[room]) < MM, room
    assert plan["start"] == "clinic_charger" and len(plan["doors"]) == 21
    said = console("floorplan", "check", str(geo))
    assert said.code == 0 and "no problems" in said.out, said.out + said.err


def test_the_clinic_in_pixels_and_in_wgs84_has_the_same_rooms_and_doors(geo, pixels):
    flat, round_earth = (yaml.safe_load(path.read_text()) for path in (pixels, geo))
    mx, my = clinic_wgs84_text()[1]
    shift = (mx, my - HEIGHT_M)  # the pixel map's frame is design y less HEIGHT_M

    def moved(point: list[float]) -> tuple[float, float]:
        return point[0] + shift[0], point[1] + shift[1]

    assert set(flat["rooms"]) == set(round_earth["rooms"])
    for room, place in round_earth["rooms"].items():
        assert math.dist(moved(place["at"]), flat["rooms"][room]["at"]) < MM, room
    doors = {door["id"]: door for door in flat["doors"]}
    assert {door["id"] for door in round_earth["doors"]} == set(doors)
    for door in round_earth["doors"]:
        same = doors[door["id"]]
        assert door["between"] == same["between"]
        assert math.dist(moved(door["at"]), same["at"]) < MM, door["id"]
        assert abs(door.get("width", 0) - same.get("width", 0)) < MM, door["id"]


def test_plan_routes_the_wgs84_clinic_as_the_pixel_one(geo, pixels):
    routes = []
    for path in (geo, pixels):
        said = console("plan", "--floorplan", str(path), "clinic_charger", "ward_d", "--json")
        assert said.code == 0, said.err
        routes.append(json.loads(said.out))
    assert routes[0]["doors"] == routes[1]["doors"]
    assert routes[0]["rooms"][-2:] == ["ward_corridor", "ward_d"]
    assert abs(routes[0]["length_m"] - routes[1]["length_m"]) < 0.01


def test_go_drives_the_wgs84_clinic_to_its_rooms_in_the_simulator(geo):
    goals = ["ward_d", "treatment_1", "day_room_tv"]
    # Spawned, as test_rmf_buildings drives: a fork of a process with threads can hang.
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        drives = list(pool.map(go_json, [geo] * len(goals), goals, timeout=GO_TIMEOUT_S))
    for room, (code, out, err) in zip(goals, drives, strict=True):
        # No markers on the imported plan: arrived by the odometry, unconfirmed (exit 3).
        assert code == 3, err
        report = json.loads(out)
        assert report["outcome"] == "arrived_unverified" and report["why"] == "done", report
        assert report["error_m"] <= 0.03, (room, report)


def test_bad_numbers_in_a_wgs84_building_are_each_told_at_their_line(tmp_path):
    lines = clinic_wgs84_text()[0].splitlines()
    first = lines.index("    vertices:") + 1
    bad = {
        first: '      - [18.06, 95.0, 0, ""]',  # beyond the pole
        first + 1: '      - [.nan, 59.33, 0, ""]',
        first + 2: '      - [1250.0, 800.0, 0, ""]',  # drawing pixels
        first + 3: '      - [59.33, 18.06, 0, ""]',
    }  # longitude and latitude swapped
    for index, line in bad.items():
        lines[index] = line
    source = tmp_path / "bad.building.yaml"
    source.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.yaml"
    said = console("floorplan", "import", str(source), str(out))
    assert said.code == 2
    at = [f"{source}:{index + 1}: levels.L1.vertices[{index - first}] " for index in bad]
    assert f"{at[0]}should begin with a longitude from -180 to 180 and a latitude" in said.err
    assert f"{at[1]}should be [longitude, latitude, z, name, {{parameters}}]" in said.err
    assert f"{at[2]}should begin with a longitude" in said.err and "pixels or metres?" in said.err
    assert f"{at[3]}[59.33, 18.06] is " in said.err
    assert f"more than {EXTENT_M / 1000:g} km: longitude and latitude swapped" in said.err
    assert "Traceback" not in said.err and not out.exists()


def test_the_levels_of_a_wgs84_building_share_one_frame(tmp_path):
    # The office of rmf_buildings on two levels: each imported alone is in the frame of
    # the whole building's middle, so a room above another is above it in the plans.
    levels = {"L1": level_one(), "L2": level_two()}
    centre = middle(*levels.values())
    text = ["coordinate_system: wgs84", "levels:"]
    for name, level in levels.items():
        text += [f"  {name}:", level.yaml("wgs84", walls=True, place=placing(centre))]
    source = tmp_path / "office.building.yaml"
    source.write_text("\n".join([*text, "name: office", ""]))
    for name, level in levels.items():
        out = tmp_path / f"{name}.yaml"
        said = console("floorplan", "import", str(source), str(out), "--level", name)
        assert said.code == 0, said.err
        rooms = yaml.safe_load(out.read_text())["rooms"]
        drawn: dict[str, tuple[float, float]] = {}
        for x, y, room, _ in level.vertices:  # the first of a name keeps it
            drawn.setdefault(room, (x - centre[0], y - centre[1]))
        drawn.pop("tinyRobot1_charger", None)  # moved clear of its wall
        kept = [room for room in drawn if room in rooms]
        assert len(kept) >= 8, (name, kept)
        for room in kept:
            assert math.dist(rooms[room]["at"], drawn[room]) < MM, (name, room)
