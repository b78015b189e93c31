"""The promises the repository makes about itself: quick start, CI and style."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def quick_start_commands() -> list[str]:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return [block.strip() for block in re.findall(r"```sh\n(.*?)```", section, re.S)]


def test_the_quick_start_has_exactly_two_commands():
    commands = quick_start_commands()
    assert len(commands) == 2
    assert all("\n" not in command for command in commands)
    assert "giraff-console" in commands[0]
    assert "pytest" in commands[1] and ".[test]" in commands[1]


def test_ci_runs_the_readme_test_command_verbatim():
    ci = (ROOT / ".ci" / "run").read_text()
    assert quick_start_commands()[1] in ci.splitlines()


def test_the_test_extra_pins_pytest_below_9_for_the_snapshot_plugin():
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert '"pytest>=8,<9"' in pyproject


def test_the_code_passes_ruff():
    # ruff comes with the test extra.
    result = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "giraff_console", "tests", "bench"],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_code_passes_mypy():
    # mypy comes with the test extra; the libraries without type information are named in
    # pyproject.toml.
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "giraff_console"],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_installed_package_carries_the_console_stylesheet(wheel):
    # A plain install from a clean checkout is what the README's run command does.
    assert "giraff_console/tui/app.tcss" in zipfile.ZipFile(wheel).namelist()


# What each part of the package may import (design.md, "The shape"): the layers below it.
# The simulator stands apart: it knows the wire format and nothing of the console.
ALLOWED_IMPORTS = {
    "protocol": {"protocol"},
    "clock": set(),
    # Reading YAML with a line for every problem: a leaf that any layer may use.
    "yaml_source": set(),
    # The settings file's path is found where the data folders are (data_folders.py).
    "settings": {
        "missions",
        "motion",
        "planning",
        "robot",
        "link",
        "protocol",
        "clock",
        "data_folders",
    },
    "sim": {"sim", "protocol", "clock"},
    "link": {"link", "protocol", "clock"},
    "camera": {"camera", "clock", "yaml_source"},
    # The range sensor (issue 29), at the camera's level: its reading code and its scans.
    "lidar": {"lidar", "link", "protocol", "clock"},
    "recording": {"recording", "camera", "link", "protocol", "clock", "yaml_source"},
    "robot": {"robot", "recording", "camera", "link", "protocol", "clock", "yaml_source"},
    "planning": {
        "planning",
        "robot",
        "recording",
        "camera",
        "link",
        "protocol",
        "clock",
        "yaml_source",
    },
    "motion": {"motion", "robot", "recording", "camera", "link", "protocol", "clock"},
    "missions": {
        "missions",
        "planning",
        "motion",
        "robot",
        "recording",
        "camera",
        "link",
        "protocol",
        "clock",
        "yaml_source",
    },
    "service": {
        "service",
        "missions",
        "planning",
        "motion",
        "robot",
        "recording",
        "camera",
        "link",
        "protocol",
        "clock",
        "yaml_source",
    },
}
# Writing a file owner-only (issue 30): a leaf that any layer but the simulator may use.
ALLOWED_IMPORTS["private_files"] = set()
for _part, _below in ALLOWED_IMPORTS.items():
    if _part != "sim":
        _below.add("private_files")
# How large a file may be read (issue 30): a leaf that every reader of files asks, the
# settings' [limits] table sets.
ALLOWED_IMPORTS["file_limits"] = set()
for _below in ALLOWED_IMPORTS.values():
    _below.add("file_limits")
ALLOWED_IMPORTS["runtime"] = ALLOWED_IMPORTS["service"] | {"runtime", "settings", "sim",
                                                           "data_folders", "lidar"}  # fmt: skip
# The fleet link is a client of the service, as the screen is; the composition root
# (cli/serve.py with runtime/) starts it, and it builds nothing of the robot itself.
ALLOWED_IMPORTS["fleet"] = ALLOWED_IMPORTS["service"] | {"fleet", "settings"}
# Issue 15: the screen asks the robot service and builds nothing itself. What it may
# still take from below: the data it draws (telemetry, poses, the plan for the map, the
# camera's pictures), never the parts that act on the robot.
TUI_MAY_NOT_IMPORT = (
    "giraff_console.missions.drive_setup",
    "giraff_console.missions.route_book",
    "giraff_console.missions.sessions",
    "giraff_console.missions.go_to",
    "giraff_console.missions.patrol",
    "giraff_console.robot.command_guard",
    "giraff_console.robot.safety",
    "giraff_console.runtime.sim_site",
    "giraff_console.sim",
)


def test_each_layer_imports_only_the_layers_below_it():
    package = ROOT / "giraff_console"
    wrong = []
    for path in package.rglob("*.py"):
        part = path.relative_to(package).parts[0].removesuffix(".py")
        if part not in ALLOWED_IMPORTS:
            continue  # tui/, cli/ and the entry points may use everything
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            for name in names:
                if name.startswith("giraff_console."):
                    layer = name.split(".")[1]
                    if layer not in ALLOWED_IMPORTS[part] | {"__init__"}:
                        wrong.append(f"{path.relative_to(ROOT)} imports {name}")
    assert wrong == []


def test_the_screen_acts_on_the_robot_only_through_the_service():
    wrong = []
    for path in (ROOT / "giraff_console" / "tui").rglob("*.py"):
        source = path.read_text()
        for node in ast.walk(ast.parse(source)):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            if module is not None and module.startswith(TUI_MAY_NOT_IMPORT):
                wrong.append(f"{path.relative_to(ROOT)} imports {module}")
            # The loop is started and stopped by the screen that runs it in its own
            # process, and nothing else: every other call on it is a request.
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Attribute)
                and node.value.attr == "control"
                and node.attr not in ("start", "stop")
            ):
                wrong.append(f"{path.relative_to(ROOT)}:{node.lineno} uses control.{node.attr}")
    assert wrong == []


def test_missions_that_drive_by_the_plan_are_built_in_one_place():
    # Issue 15: `go` was built in four places with the same seven arguments. Every front
    # end now asks missions/drive_setup.py, and only docking.py's go_mission (which it
    # calls) builds the missions themselves.
    builders = {"go_mission", "GoTo", "GoToPose", "FollowRoute"}
    allowed = {"giraff_console/missions/drive_setup.py", "giraff_console/missions/docking.py"}
    wrong = []
    for path in (ROOT / "giraff_console").rglob("*.py"):
        where = path.relative_to(ROOT).as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name | ast.Attribute):
                name = node.func.id if isinstance(node.func, ast.Name) else node.func.attr
                if name in builders and where not in allowed:
                    wrong.append(f"{where}:{node.lineno} builds {name}")
    assert wrong == []


# The words a mission's end is told in: what the code compared before its ends were
# typed (issue 26).
END_WORDS = ("done", "not started", "stopped", "replaced", "failed")


def _is_end_words(node: ast.AST) -> bool:
    return (isinstance(node, ast.Constant) and isinstance(node.value, str)
            and node.value.startswith(END_WORDS))  # fmt: skip


def _named(node: ast.AST) -> str | None:
    """The name a value goes by: `why`, `end.why`, `summary["why"]`."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
        return str(node.slice.value)
    return None


def test_no_mission_outcome_is_decided_by_comparing_its_words():
    # Issue 26: `== "done"` and `startswith("not started")` decided outcomes in six
    # modules. A mission ends with an Outcome (robot/mission.py, MissionEnd); its words
    # are for people. Caught here: a `why`, or a mission's end words, compared.
    wrong = []
    for path in (ROOT / "giraff_console").rglob("*.py"):
        where = path.relative_to(ROOT).as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                sides = [node.left, *node.comparators]
                named_why = any(_named(side) in ("why", "ended") for side in sides)
                if named_why and any(_is_end_words(side) or isinstance(side, ast.List)
                                     for side in sides):  # fmt: skip
                    wrong.append(f"{where}:{node.lineno}")
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("startswith", "endswith")
                    and any(_is_end_words(arg) for arg in node.args)):  # fmt: skip
                wrong.append(f"{where}:{node.lineno}")
    assert wrong == []


# What only the composition root builds: the robot's parts (issue 26).
ROBOT_PARTS = ("ControlLoop", "RobotService", "Sessions", "RouteBook", "SimulatedSite",
               "control_loop", "camera_feed", "route_book", "on_loop")  # fmt: skip


def test_the_robot_is_assembled_in_one_place_the_runtime():
    # Issue 26: the robot was put together in four places (the console, `go`/`patrol`,
    # the daemon, the test rig). Only runtime/ builds its parts now; a route book builds
    # its own missions' set-up for a route being taught (missions/route_book.py).
    wrong = []
    for path in (ROOT / "giraff_console").rglob("*.py"):
        where = path.relative_to(ROOT).as_posix()
        if where.startswith("giraff_console/runtime/"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name | ast.Attribute):
                name = node.func.id if isinstance(node.func, ast.Name) else node.func.attr
                allowed = where == "giraff_console/missions/route_book.py" and name == "on_loop"
                if name in ROBOT_PARTS and not allowed:
                    wrong.append(f"{where}:{node.lineno} builds {name}")
    assert wrong == []


def test_the_screen_imports_nothing_from_the_robot_or_its_missions():
    # Issue 26: the TUI is given the service and nothing else. What it draws comes in
    # the service's words (service/vocabulary.py), the same in its own process and
    # across the daemon's socket; it never reaches into robot/ or missions/.
    wrong = []
    for path in (ROOT / "giraff_console" / "tui").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            below = ("giraff_console.robot", "giraff_console.missions")
            wrong += [f"{path.relative_to(ROOT)} imports {name}" for name in names
                      if name.startswith(below)]  # fmt: skip
    assert wrong == []
