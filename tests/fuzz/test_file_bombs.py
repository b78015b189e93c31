"""The bombs (issue 30): every kind of file the console reads, made to take all the memory
a robot's PC has or all the time there is, is refused at once by the real command.

Each case runs `giraff-console` as an operator would, in a process of its own, and asks
of it what the issue asks: exit 2, a `file:line` (or `file:`) message, no traceback,
within 5 s of wall time and 300 MB of its own peak memory (its rusage, read as it ends;
killed at the deadline). Without the limits these took 47 s and 5.2 GB (a billion
laughs), 4.7 GB (/dev/zero), 66 s and 5.2 GB (100,000 markers), or never ended (a FIFO).
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from giraff_console import file_limits
from giraff_console.file_limits import FileLimits, current, use
from giraff_console.planning.floorplan import FloorPlanError, load_floorplan
from giraff_console.planning.ros_map import grid_image_problem
from tests.fuzz.bounded_run import DEADLINE_S, Finished, run_bounded
from tests.fuzz.inputs import dev_zero, fifo, laughs, pgm_header, png, sparse, white_rows

PEAK_KIB = 300 * 1024
SAMPLE = Path(__file__).parents[2] / "recordings" / "sample"


def assert_refused(finished: Finished, blamed: Path) -> None:
    """Exit 2 within the deadline and the memory, `blamed` named as `file:line:` or
    `file:`, and no traceback."""
    cpu, peak = finished.cpu_seconds, finished.peak_kib / 1024
    took = f"{finished.seconds:.1f} s ({cpu:.1f} s CPU), {peak:.0f} MB"
    shown = f"{took}: {finished.said[-2000:]}"
    assert finished.status == 2, shown
    assert "Traceback" not in finished.said, shown
    assert re.search(rf"{re.escape(str(blamed))}(:\d+)?: ", finished.said), shown
    assert finished.seconds <= DEADLINE_S, shown
    assert finished.peak_kib <= PEAK_KIB, shown


# What each bomb is made of: writes the file at `path` (or a link, or a FIFO).
Bomb = Callable[[Path], Path]


def written(data: bytes) -> Bomb:
    def make(path: Path) -> Path:
        path.write_bytes(data)
        return path

    return make


def _lines(head: list[str], item: str, count: int) -> bytes:
    return ("\n".join(head + [item.format(i=i) for i in range(count)]) + "\n").encode()


_ROOM = "  r{i}: {{at: [1, 1]}}"
_DOOR = "  - {{between: [a, b], at: [1, 1]}}"
_MARKER = "    - {{id: {i}, at: [1.5, 2.0], height: 1.2, facing: 90}}"
_PLAN_HEAD = ["name: bomb", "rooms:", "  a: {at: [1, 1]}", "  b: {at: [3, 1]}"]
_LANDMARKS_HEAD = [*_PLAN_HEAD, "doors: []", "landmarks:", "  family: apriltag_36h11",
                   "  size: 0.15", "  markers:"]  # fmt: skip

# Bombs any file of YAML is made of: refused before anything looks at its keys.
YAML_BOMBS: dict[str, Bomb] = {
    "billion laughs": written(laughs()),
    "a list that holds itself": written(b"a: &a [1, *a]\n"),
    "nested 100,000 deep": written(b"a: " + b"[" * 100_000 + b"]" * 100_000 + b"\n"),
    "/dev/zero": dev_zero,
    "a FIFO": fifo,
    "20 GB by its size": lambda path: sparse(path, 20 * 10**9),
}
# A floor plan's own: more rooms, doors or markers than the limits.
PLAN_BOMBS: dict[str, Bomb] = {
    **YAML_BOMBS,
    "100,000 markers": written(_lines(_LANDMARKS_HEAD, _MARKER, 100_000)),
    "100,000 rooms": written(_lines(["name: bomb", "rooms:"], _ROOM, 100_000)),
    "100,000 doors": written(_lines([*_PLAN_HEAD, "doors:"], _DOOR, 100_000)),
    "one marker over the limit": written(_lines(_LANDMARKS_HEAD, _MARKER, 10_001)),
    "one room over the limit": written(_lines(["name: bomb", "rooms:"], _ROOM, 5_001)),
    "one door over the limit": written(_lines([*_PLAN_HEAD, "doors:"], _DOOR, 10_001)),
}
# A grid image's: headers claiming 10 gigapixels, a real image of 144 megapixels (all
# white, so a few hundred kB), and files that are not files.
IMAGE_BOMBS: dict[str, Bomb] = {
    "a PGM claiming 100000 x 100000": written(pgm_header(100_000, 100_000)),
    "a PNG claiming 100000 x 100000": written(png(100_000, 100_000)),
    "a real PNG of 12000 x 12000": written(png(12_000, 12_000, white_rows(12_000, 12_000))),
    "/dev/zero": dev_zero,
    "a FIFO": fifo,
    "20 GB by its size": lambda path: sparse(path, 20 * 10**9),
}


def _plan_on_grid(folder: Path, image: str) -> Path:
    """A floor plan of two rooms on the grid image `image`, beside it."""
    plan = folder / "plan.yaml"
    plan.write_text(
        "name: gridded\nrooms:\n  a: {at: [1, 1]}\n  b: {at: [3, 1]}\n"
        "doors:\n  - {between: [a, b], at: [2, 1]}\n"
        f"grid:\n  image: {image}\n  resolution: 0.05\n"
    )
    return plan


@pytest.mark.parametrize("bomb", PLAN_BOMBS, ids=str)
def test_floorplan_check_refuses_a_plan_bomb(tmp_path, bomb):
    plan = PLAN_BOMBS[bomb](tmp_path / "plan.yaml")
    assert_refused(run_bounded(tmp_path, "floorplan", "check", str(plan)), plan)


# Every command that reads a floor plan, with the plan's path where FILE is.
PLAN_COMMANDS = {
    "floorplan show": ("floorplan", "show", "FILE"),
    "plan": ("plan", "--floorplan", "FILE", "a", "b"),
    "go --sim": ("go", "--sim", "--floorplan", "FILE", "b"),
    "floorplan landmarks --print": ("floorplan", "landmarks", "--print", "pages", "FILE"),
}


@pytest.mark.parametrize("bomb", ["billion laughs", "/dev/zero", "a FIFO", "100,000 markers"])
@pytest.mark.parametrize("command", PLAN_COMMANDS)
def test_every_command_refuses_a_plan_bomb(tmp_path, command, bomb):
    plan = PLAN_BOMBS[bomb](tmp_path / "plan.yaml")
    args = [str(plan) if arg == "FILE" else arg for arg in PLAN_COMMANDS[command]]
    assert_refused(run_bounded(tmp_path, *args), plan)


@pytest.mark.parametrize("bomb", IMAGE_BOMBS, ids=str)
@pytest.mark.parametrize("command", ["floorplan check", "plan"])
def test_a_grid_image_bomb_is_refused(tmp_path, command, bomb):
    image = IMAGE_BOMBS[bomb](tmp_path / "grid.png")
    plan = _plan_on_grid(tmp_path, image.name)
    args = ("floorplan", "check", str(plan)) if command == "floorplan check" else (
        "plan", "--floorplan", str(plan), "a", "b")  # fmt: skip
    # The grid's problem is the plan's, at the line of its `image` key.
    assert_refused(run_bounded(tmp_path, *args), plan)


def _ros_map(folder: Path, image: str) -> Path:
    path = folder / "map.yaml"
    path.write_text(
        f"image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return path


@pytest.mark.parametrize("bomb", YAML_BOMBS, ids=str)
def test_a_ros_map_bomb_is_refused(tmp_path, bomb):
    # A scanned map, as `floorplan rooms` reads it: the FIFO hung it.
    scan = YAML_BOMBS[bomb](tmp_path / "map.yaml")
    out = tmp_path / "out.yaml"
    assert_refused(run_bounded(tmp_path, "floorplan", "rooms", str(scan), str(out)), scan)
    assert not out.exists()


@pytest.mark.parametrize("bomb", IMAGE_BOMBS, ids=str)
def test_a_ros_map_image_bomb_is_refused(tmp_path, bomb):
    image = IMAGE_BOMBS[bomb](tmp_path / "map.png")
    scan = _ros_map(tmp_path, image.name)
    out = tmp_path / "out.yaml"
    assert_refused(run_bounded(tmp_path, "floorplan", "rooms", str(scan), str(out)), scan)


_LEVEL_HEAD = ["levels:", "  L1:", "    elevation: 0", "    vertices:",
               "      - [0, 0, 0, a]", "      - [100, 0, 0, b]"]  # fmt: skip
# An Open-RMF building's: a level of more vertices or doors than the limits.
BUILDING_BOMBS: dict[str, Bomb] = {
    **YAML_BOMBS,
    "100,000 vertices": written(_lines(_LEVEL_HEAD, "      - [{i}, 5, 0, '']", 100_000)),
    "one door over the limit": written(
        _lines([*_LEVEL_HEAD, "    doors:"], "      - [0, 1, {{name: d{i}}}]", 10_001)
    ),
}


@pytest.mark.parametrize("bomb", BUILDING_BOMBS, ids=str)
def test_an_rmf_building_bomb_is_refused(tmp_path, bomb):
    source = BUILDING_BOMBS[bomb](tmp_path / "site.building.yaml")
    out = tmp_path / "out.yaml"
    assert_refused(run_bounded(tmp_path, "floorplan", "import", str(source), str(out)), source)
    assert not out.exists()


_STOP = "  - {{room: b}}"
# A patrol's: more stops than the limits; a route's: more points on its path.
PATROL_BOMBS: dict[str, Bomb] = {
    **YAML_BOMBS,
    "100,001 stops": written(_lines(["rounds: 1", "stops:"], _STOP, 100_001)),
    "one stop over the limit": written(_lines(["rounds: 1", "stops:"], _STOP, 20_001)),
}
_ROUTE_HEAD = ["format: 1", "taught: '2026-01-01T00:00:00'", "duration: 1", "settings: {}",
               "commands: []", "path:"]  # fmt: skip
ROUTE_BOMBS: dict[str, Bomb] = {
    **YAML_BOMBS,
    "100,001 points": written(_lines(_ROUTE_HEAD, "  - [0, 0, 0, 0]", 100_001)),
}


def _plan(folder: Path) -> Path:
    plan = folder / "plan.yaml"
    plan.write_text("\n".join([*_PLAN_HEAD, "doors:", "  - {between: [a, b], at: [2, 1]}"]))
    return plan


@pytest.mark.parametrize("bomb", PATROL_BOMBS, ids=str)
def test_a_patrol_bomb_is_refused(tmp_path, bomb):
    routes = tmp_path / "routes"
    routes.mkdir()
    patrol = PATROL_BOMBS[bomb](routes / "rounds.patrol.yaml")
    finished = run_bounded(tmp_path, "patrol", "--sim", "--routes", str(routes),
                           "--floorplan", str(_plan(tmp_path)), "rounds")  # fmt: skip
    assert_refused(finished, patrol)


@pytest.mark.parametrize("bomb", ROUTE_BOMBS, ids=str)
def test_a_route_bomb_is_refused(tmp_path, bomb):
    # A patrol whose stop follows a taught route: the route is read as the patrol is.
    routes = tmp_path / "routes"
    routes.mkdir()
    (routes / "rounds.patrol.yaml").write_text("rounds: 1\nstops:\n  - {route: corridor}\n")
    route = ROUTE_BOMBS[bomb](routes / "corridor.yaml")
    finished = run_bounded(tmp_path, "patrol", "--sim", "--routes", str(routes),
                           "--floorplan", str(_plan(tmp_path)), "rounds")  # fmt: skip
    assert_refused(finished, route)


@pytest.mark.parametrize("bomb", YAML_BOMBS, ids=str)
def test_a_camera_calibration_bomb_is_refused(tmp_path, bomb):
    calibration = YAML_BOMBS[bomb](tmp_path / "calibration.yaml")
    assert_refused(run_bounded(tmp_path, "--calibration", str(calibration)), calibration)


def _session(folder: Path) -> Path:
    """A copy of the sample recording, to spoil one file of."""
    session = folder / "session"
    shutil.copytree(SAMPLE, session)
    return session


LOG_BOMBS: dict[str, Bomb] = {
    "/dev/zero": dev_zero,
    "a FIFO": fifo,
    "20 GB by its size": lambda path: sparse(path, 20 * 10**9),
}
META_BOMBS: dict[str, Bomb] = {
    **LOG_BOMBS,
    "nested 100,000 deep": written(b"[" * 100_000 + b"]" * 100_000),
}


@pytest.mark.parametrize("bomb", LOG_BOMBS, ids=str)
@pytest.mark.parametrize("command", ["export", "replay"])
def test_a_control_log_bomb_is_refused(tmp_path, command, bomb):
    session = _session(tmp_path)
    (session / "control.log").unlink()
    log = LOG_BOMBS[bomb](session / "control.log")
    args = ("export", str(session), str(tmp_path / "out.mcap")) if command == "export" else (
        "replay", str(session))  # fmt: skip
    assert_refused(run_bounded(tmp_path, *args), log)


@pytest.mark.parametrize("bomb", META_BOMBS, ids=str)
def test_a_meta_json_bomb_is_refused(tmp_path, bomb):
    session = _session(tmp_path)
    (session / "meta.json").unlink()
    meta = META_BOMBS[bomb](session / "meta.json")
    finished = run_bounded(tmp_path, "export", str(session), str(tmp_path / "out.mcap"))
    assert_refused(finished, meta)


@pytest.mark.parametrize("where", ["camera.mp4", "camera.frames.csv"])
def test_a_fifo_where_the_video_belongs_is_passed_over(tmp_path, where):
    # OpenCV's open of a FIFO would block for ever: the session exports without it.
    session = _session(tmp_path)
    (session / where).unlink()
    fifo(session / where)
    finished = run_bounded(tmp_path, "export", str(session), str(tmp_path / "out.mcap"))
    assert finished.status == 0, finished
    assert finished.peak_kib <= PEAK_KIB, finished


# The limits themselves, in this process.


def test_an_airport_s_grid_passes_the_limits():
    # 300 x 150 m at 0.05 m a cell: the header is checked, nothing is planned on.
    width, height = 6000, 3000
    assert grid_image_problem(pgm_header(width, height) + bytes(width * height)) is None
    assert grid_image_problem(png(width, height, white_rows(width, height))) is None


@pytest.fixture
def limits():
    """The limits as they were, whatever a test sets."""
    before = current()
    yield
    use(before)


def test_raising_a_limit_lets_a_refused_plan_through(tmp_path, limits):
    plan = tmp_path / "plan.yaml"
    doors = [f"  - {{between: [r{i}, r{i + 1}], at: [1, 1]}}" for i in range(11)]
    plan.write_bytes(_lines(["name: many", "doors:", *doors, "rooms:"], _ROOM, 12))
    use(replace(current(), rooms=11))
    with pytest.raises(FloorPlanError, match=r"12 rooms, more than the 11 this console reads"):
        load_floorplan(plan)
    use(replace(current(), rooms=12))
    assert len(load_floorplan(plan).rooms) == 12


def test_raising_the_pixel_limit_lets_a_larger_grid_through(limits):
    image = png(6000, 3000)
    use(replace(current(), image_pixels=6000 * 3000 - 1))
    assert "6000 x 3000 pixels, more than the 17,999,999" in str(grid_image_problem(image))
    use(replace(current(), image_pixels=6000 * 3000))
    assert grid_image_problem(image) is None


def test_raising_the_node_limit_lets_more_aliases_through(tmp_path, limits):
    plan = tmp_path / "plan.yaml"
    # Some 250 nodes with the aliases expanded.
    plan.write_bytes(b"name: x\nrooms: {a: {at: &p [1, 1]}, b: {at: *p}}\n" + laughs(2))
    use(replace(current(), yaml_nodes=100))
    with pytest.raises(FloorPlanError, match="more than 100 YAML nodes"):
        load_floorplan(plan)
    use(replace(current(), yaml_nodes=1_000))
    with pytest.raises(FloorPlanError, match="unknown key a0"):  # read as far as its keys
        load_floorplan(plan)


def test_raising_the_byte_limit_lets_a_larger_file_through(tmp_path, limits):
    path = tmp_path / "big"
    path.write_bytes(b"x" * 1000)
    use(replace(current(), file_bytes=999))
    with pytest.raises(file_limits.FileRefused, match="1,000 bytes, more than the 999"):
        file_limits.read_bounded(path)
    use(replace(current(), file_bytes=1000))
    assert file_limits.read_bounded(path) == b"x" * 1000


def test_every_limit_is_a_positive_int_named_as_a_toml_key():
    # The settings file's [limits] table is read by these names (settings.py).
    for name, value in vars(FileLimits()).items():
        assert re.fullmatch(r"[a-z][a-z0-9_]*", name) and isinstance(value, int) and value > 0
