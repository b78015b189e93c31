"""Where recordings, routes and the example floor plan live when nobody says."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from giraff_console.cli.main import build_parser
from giraff_console.data_folders import (
    data_folder,
    data_home,
    default_recordings,
    default_routes,
    example_floorplan,
    example_routes,
)
from giraff_console.missions.docking import DOCK
from giraff_console.missions.patrol import load_patrol
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.settings import SettingsError, load_settings


@pytest.fixture
def home(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    return tmp_path / "home"


def test_without_xdg_data_home_the_data_lives_under_local_share(home):
    assert data_home() == home / ".local" / "share" / "giraff-console"
    assert default_recordings() == data_home() / "recordings"
    assert default_routes() == data_home() / "routes"


def test_xdg_data_home_moves_it_and_a_relative_one_is_ignored(home, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert data_home() == tmp_path / "data" / "giraff-console"
    # The XDG spec: a relative path is invalid and must be ignored.
    monkeypatch.setenv("XDG_DATA_HOME", "data")
    assert data_home() == home / ".local" / "share" / "giraff-console"


def test_the_command_line_comes_before_the_settings_and_the_settings_before_the_default(home):
    default = default_recordings()
    assert data_folder(Path("cli"), "/settings", default) == Path("cli")
    assert data_folder(None, "/settings", default) == Path("/settings")
    assert data_folder(None, None, default) == default


def test_the_default_folder_is_made_owner_only_and_its_leaf_only_on_first_use(home):
    folder = data_folder(None, None, default_recordings())
    assert stat.S_IMODE(folder.parent.stat().st_mode) == 0o700
    assert not folder.exists()  # made by the first recording, inside the private parent


def test_a_folder_given_is_not_made_by_choosing_it(home, tmp_path):
    data_folder(tmp_path / "mine", None, default_recordings())
    data_folder(None, str(tmp_path / "set"), default_recordings())
    assert not (tmp_path / "mine").exists() and not (tmp_path / "set").exists()
    assert not data_home().exists()


def test_settings_folders_are_taken_from_the_settings_files_folder(home, tmp_path):
    config = tmp_path / "config" / "config.toml"
    config.parent.mkdir()
    config.write_text('recordings = "sessions"\nroutes = "~/taught"\n')
    settings = load_settings(config)
    assert settings.recordings == str(tmp_path / "config" / "sessions")
    assert settings.routes == str(home / "taught")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("recordings = 3", "recordings must be a text in quotes, not a whole number"),
        ('routes = " "', "routes must name a folder"),
        ('routes = "a\\u0000b"', "routes must name a folder"),
    ],
)
def test_bad_folder_settings_are_refused_with_the_key(tmp_path, text, message):
    config = tmp_path / "config.toml"
    config.write_text(text)
    with pytest.raises(SettingsError, match=message):
        load_settings(config)


def test_the_command_line_leaves_the_folders_to_the_settings_and_says_the_defaults(home):
    parser = build_parser()
    args = parser.parse_args([])
    assert args.recordings is None and args.routes is None
    # argparse wraps a path longer than the line anywhere: compare without whitespace.
    text = "".join(parser.format_help().split())
    for folder in (default_recordings(), default_routes()):
        assert str(folder) in text


def test_the_example_floor_plan_ships_in_the_package_with_its_grid():
    plan = load_floorplan(example_floorplan())
    assert example_floorplan().parent.name == "floorplans"
    assert "giraff_console" in example_floorplan().parts
    assert plan.grid is not None and plan.grid.image.is_file()
    assert {"dock", "kitchen"} <= set(plan.rooms)


def test_the_example_night_patrol_ships_in_the_package_for_the_example_plan():
    """The README's `patrol night`: its rooms are the example plan's, and it drives no
    taught route, so a fresh install has all it needs."""
    assert "giraff_console" in example_routes().parts
    patrol = load_patrol(example_routes() / "night.patrol.yaml")
    rooms = load_floorplan(example_floorplan()).rooms
    assert patrol.stops and all(stop.route is None for stop in patrol.stops)
    assert all(stop.room in rooms or stop.room == DOCK for stop in patrol.stops)
    assert patrol.stops[-1].room == DOCK  # back to charge
