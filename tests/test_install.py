"""A clean install works from any folder: the console's files come from the package and
the operator's data folder, never from the folder it happens to be started in."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def installed(wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The package as `pip install .` lays it out: the wheel, unpacked."""
    site = tmp_path_factory.mktemp("install") / "site"
    zipfile.ZipFile(wheel).extractall(site)
    return site


@pytest.fixture
def elsewhere(tmp_path) -> Path:
    """An empty folder outside the repository, to start the console in."""
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    return folder


# `go kitchen` with the simulated camera takes about 22 s on a quiet 2-core machine and
# over 60 s beside two busy loops and other work.
COMMAND_TIMEOUT_S = 180


def giraff_console(installed: Path, elsewhere: Path, *args: str) -> subprocess.CompletedProcess:
    """`giraff-console ARGS` from the installed package, started in `elsewhere`, with a
    home of its own and no settings file."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "PYTHON"))}
    # Before the site-packages that hold the editable install, so the wheel is imported.
    env["PYTHONPATH"] = str(installed)
    env["HOME"] = str(elsewhere.parent / "home")
    return subprocess.run(
        [sys.executable, "-m", "giraff_console", *args],
        cwd=elsewhere, env=env, capture_output=True, text=True, timeout=COMMAND_TIMEOUT_S,
    )  # fmt: skip


def test_the_package_imported_is_the_installed_one(installed, elsewhere):
    env = {**os.environ, "PYTHONPATH": str(installed)}
    result = subprocess.run(
        [sys.executable, "-c", "import giraff_console; print(giraff_console.__file__)"],
        cwd=elsewhere, env=env, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert Path(result.stdout.strip()).is_relative_to(installed), result.stderr


def test_plan_uses_the_example_that_ships_with_the_package(installed, elsewhere):
    result = giraff_console(installed, elsewhere, "plan", "dock", "kitchen")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("dock → corridor")
    assert "kitchen" in result.stdout.splitlines()[0]


def test_go_with_the_simulator_arrives_in_the_example_building(installed, elsewhere):
    result = giraff_console(
        installed, elsewhere, "go", "kitchen", "--sim", "--sim-speed", "inf", "--json"
    )
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["arrived"] and report["room"] == "kitchen"
    assert report["error_m"] < 0.1
    assert list(elsewhere.iterdir()) == []  # nothing left in the folder it was started in


def test_the_help_says_where_recordings_and_routes_live(installed, elsewhere):
    result = giraff_console(installed, elsewhere, "--help")
    assert result.returncode == 0, result.stderr
    text = "".join(result.stdout.split())  # argparse wraps long paths anywhere
    data = elsewhere.parent / "home" / ".local" / "share" / "giraff-console"
    assert f"{data}/recordings" in text and f"{data}/routes" in text
    assert "floorplans/care-home.yaml" in text


def test_the_example_patrol_ships_in_the_wheel(wheel):
    # `patrol night`, the README's example, from a fresh install (data_folders.py).
    assert "giraff_console/routes/night.patrol.yaml" in zipfile.ZipFile(wheel).namelist()


def test_the_readmes_patrol_night_runs_from_a_fresh_install(installed, elsewhere):
    result = giraff_console(
        installed, elsewhere, "patrol", "night", "--sim", "--sim-speed", "inf", "--json"
    )
    assert result.returncode == 0, result.stderr
    *stops, summary = [json.loads(line) for line in result.stdout.splitlines()]
    assert summary["patrol"] == "night" and summary["why"] == "done"
    assert stops and all(stop["arrived"] for stop in stops)
    assert list(elsewhere.iterdir()) == []
