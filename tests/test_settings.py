"""The settings file: defaults, overrides, and clear errors for bad files."""

from __future__ import annotations

import subprocess
import sys

import pytest

from giraff_console.settings import Settings, SettingsError, load_settings


def write(tmp_path, text: str):
    path = tmp_path / "config.toml"
    path.write_text(text)
    return path


def test_no_file_means_built_in_defaults(tmp_path):
    settings = load_settings(tmp_path / "missing.toml")
    assert settings == Settings()
    assert settings.port is None  # the simulator
    assert settings.teleop.speed == 0.4 and settings.teleop.accel == 0.5


def test_a_file_overrides_what_it_names(tmp_path):
    path = write(tmp_path, 'port = "/dev/ttyUSB0"\npower_line = "rts"\n[teleop]\nspeed = 0.3\n')
    settings = load_settings(path)
    assert (settings.port, settings.power_line, settings.teleop.speed) == (
        "/dev/ttyUSB0",
        "rts",
        0.3,
    )
    assert settings.teleop.max_speed == 0.4
    assert settings.source == str(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("prot = 1", "unknown key prot"),
        ("[teleop]\nsped = 1", "unknown key teleop.sped"),
        ('timeout = "fast"', "timeout has the wrong type"),
        ("port = 3", "port has the wrong type"),
        ('power_line = "dsr"', "power_line must be"),
        ("[teleop]\nmax_speed = 0.6\nspeed = 0.6", "within 0.25 m"),
        ("[teleop]\nmax_speed = 0.6\nspeed = 0.6\naccel = 1.0", "over the 0.25 m limit"),
        ("[teleop]\ngrace = 0", "grace and repeat_timeout must be positive"),
        ("[teleop]\nundock_distance = 5", "undock_distance must be in"),
        ("timeout = [", "config.toml"),
        ("teleop = 3", "must be a table"),
        ("motion = 3", "[motion] must be a table"),
        ("[motion]\nv_max = 0.6", "may not exceed"),
        ("[motion]\nj_max = 0", "j_max"),
        ("[motion]\nwarp = 9", "unknown key motion.warp"),
    ],
)
def test_bad_files_are_refused_with_the_path_and_the_key(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SettingsError) as caught:
        load_settings(path)
    assert str(path) in str(caught.value)
    assert message in str(caught.value)


def test_the_console_refuses_a_bad_file_without_a_traceback(tmp_path):
    path = write(tmp_path, "[teleop]\nspeed = -1")
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "--config", str(path)],
        capture_output=True, text=True, timeout=20,
    )  # fmt: skip
    assert result.returncode == 2
    assert "speed must be positive" in result.stderr
    assert "Traceback" not in result.stderr
