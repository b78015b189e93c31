"""The settings file: defaults, overrides, and clear errors for bad files."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import fields
from datetime import time
from pathlib import Path

import pytest

from giraff_console.file_limits import FileLimits
from giraff_console.missions.schedule import ScheduledPatrol
from giraff_console.settings import (
    CHOICES,
    MAX_LIMIT,
    RANGES,
    Settings,
    SettingsError,
    load_settings,
)


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


def test_the_board_and_battery_tables(tmp_path):
    path = write(tmp_path, '[board]\nwheel_base = 0.467\nodometers = "increments"\n'
                           'twm = "on"\n[battery]\nlow = 30\ncharged = 95\n')  # fmt: skip
    settings = load_settings(path)
    board = settings.board
    assert (board.wheel_base, board.odometers, board.twm) == (0.467, "increments", "on")
    assert (settings.battery.low, settings.battery.charged) == (30, 95)
    defaults = Settings()
    assert (defaults.board.wheel_base, defaults.board.odometers) == (0.499, "auto")
    assert defaults.board.twm == "auto"
    assert (defaults.battery.low, defaults.battery.charged) == (25, 90)
    assert defaults.port_program_drives


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("prot = 1", ":1: unknown key prot"),
        ("[teleop]\nsped = 1", ":2: unknown key teleop.sped"),
        ('timeout = "fast"', ":1: timeout must be a number, not a text"),
        ("port = 3", ":1: port must be a text in quotes, not a whole number"),
        ('power_line = "dsr"', ":1: power_line must be one of dtr, rts, both, none, not 'dsr'"),
        ('virtual_port = "writes"', ":1: virtual_port must be one of drives, reads, not 'writes'"),
        ("virtual_port = true", ":1: virtual_port must be a text in quotes, not true or false"),
        ("[teleop]\nmax_speed = 0.6\nspeed = 0.6",
         ":2: [teleop] accel must be at least 0.720 m/s^2 to stop from max_speed within 0.25 m"),
        ("[teleop]\nmax_speed = 0.6\nspeed = 0.6\naccel = 1.0", "over the 0.25 m limit"),
        ("[teleop]\ngrace = 0", ":2: teleop.grace must be between 0.1 and 2 s, not 0 s"),
        ("[teleop]\nundock_distance = 5",
         ":2: teleop.undock_distance must be between 0.05 and 1 m, not 5 m"),
        ("\ntimeout = [", ":2: Invalid value"),
        ("timeout = 1\ntimeout = 2", ":2: Cannot overwrite a value"),
        ("teleop = 3", ":1: [teleop] must be a table"),
        ("motion = 3", ":1: [motion] must be a table"),
        ("[motion]\nv_max = 0.6", ":2: motion.v_max and motion.a_max may not exceed"),
        ("[motion]\nj_max = 0", ":2: motion.j_max must be between 0.1 and 10 m/s^3, not 0 m/s^3"),
        ("[motion]\nwarp = 9", ":2: unknown key motion.warp"),
        ("[motion]\nmax_replans = 2.5", ":2: motion.max_replans must be a whole number from 1"),
        ("board = 3", ":1: [board] must be a table"),
        ("[board]\nwheel_base = 49.9",
         ":2: board.wheel_base must be between 0.2 and 1 m, not 49.9 m: a Giraff's"),
        ("[board]\nwheel_base = 0", "not 0 m"),
        ("[board]\nwheel_base = 0.15",
         ":2: board.wheel_base must be between 0.2 and 1 m, not 0.15 m"),
        ('[board]\ntwm = "yes"', ":2: board.twm must be one of auto, on, off, not 'yes'"),
        ("[board]\ntwm = true", ":2: board.twm must be a text in quotes, not true or false"),
        ('[board]\nwheel_base = "wide"', ":2: board.wheel_base must be a number, not a text"),
        ('[board]\nodometers = "total"',
         ":2: board.odometers must be one of auto, totals, increments, encoders, not 'total'"),
        ("[board]\nodometers = 1",
         ":2: board.odometers must be a text in quotes, not a whole number"),
        ("[board]\nwheels = 2", ":2: unknown key board.wheels"),
        ("[battery]\ncharged = 80\nlow = 95",
         ":2: battery.low (95) must be below battery.charged (80)"),
        ("[battery]\ncharged = 120", ":2: battery.charged must be between 0 and 100 %, not 120 %"),
        ("[battery]\nlow = -1", ":2: battery.low must be between 0 and 100 %, not -1 %"),
        ("[lidar]\nbaudrate = 9600", ":2: lidar.baudrate must be one of 115200, 256000, not 9600"),
        ("[lidar]\nbaudrate = 115200.0",
         ":2: lidar.baudrate must be a whole number, not a number with a decimal point"),
        ("[lidar]\nrange_min = 5\nrange_max = 3", ":2: lidar.range_min must be below"),
        ("# the robot\ncontrol_rate = 1e6", ":2: control_rate must be between 10 and 30 Hz, not "
         "1e+06 Hz: the most the board's 115200 baud carries"),
        ("control_rate = 0.2", ":1: control_rate must be between 10 and 30 Hz, not 0.2 Hz"),
        ("control_rate = nan", ", not nan Hz"),
        ("max_consoles = 0", ":1: max_consoles must be between 1 and 1000, not 0"),
        ("max_consoles = 64.5", ":1: max_consoles must be a whole number from 1 to 1000, not 64.5"),
        ('[fleet]\non_broker_lost = "panic"',
         ":2: fleet.on_broker_lost must be one of carry_on, stop, not 'panic'"),
        ('recordings = " "', ":1: recordings must name a folder"),
        ("[limits]\nfile_bytes = 0",
         ":2: limits.file_bytes must be between 1 and 1099511627776, not 0"),
        ("[limits]\n\nrooms = 1e3", ":3: limits.rooms must be a whole number"),
        ("[limits]\nfile_bites = 10", ":2: unknown key limits.file_bites"),
        ('[limits]\nmarkers = "many"', ":2: limits.markers must be a whole number, not a text"),
        ("limits = 3", ":1: [limits] must be a table"),
        ("[teleop]\nspeed = 0.3\n[motion]\nv_max = 99",
         ":4: motion.v_max must be between 0.05 and 1 m/s, not 99 m/s"),
        ("x = 1\n[teleop]\ndeep.er = 1", ":3: unknown key teleop.deep"),
    ],
)  # fmt: skip
def test_bad_files_are_refused_with_the_path_and_the_line(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SettingsError) as caught:
        load_settings(path)
    assert str(caught.value).startswith(f"{path}:")
    assert message in str(caught.value)


def test_the_console_refuses_a_bad_file_without_a_traceback(tmp_path):
    path = write(tmp_path, "[teleop]\nspeed = -1")
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "--config", str(path)],
        capture_output=True, text=True, timeout=120,  # it loads Textual first
    )  # fmt: skip
    assert result.returncode == 2
    assert f"{path}:2: teleop.speed must be between 0.05 and 1 m/s, not -1 m/s" in result.stderr
    assert "Traceback" not in result.stderr


NIGHT_TABLE = '[[schedule]]\npatrol = "night"\nevery = "2h"\nfrom = "22:00"\nto = "06:00"\n'


def test_scheduled_patrols_are_read_in_order(tmp_path):
    path = write(tmp_path, 'port = "/dev/ttyS0"\n' + NIGHT_TABLE
                           + '[[schedule]]\npatrol = "garden"\nevery = "1h30m"\n')  # fmt: skip
    settings = load_settings(path)
    assert settings.port == "/dev/ttyS0"
    assert settings.schedule == (
        ScheduledPatrol("night", 7200.0, time(22, 0), time(6, 0)),
        ScheduledPatrol("garden", 5400.0, time(0, 0), time(0, 0)),
    )
    assert Settings().schedule == ()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (NIGHT_TABLE.replace('every = "2h"', 'every = "2 hours"'),
         ':3: schedule[0].every should be a duration such as "2h"'),
        (NIGHT_TABLE.replace('"2h"', '"5m"'),
         ":3: schedule[0].every is 5m: it must be at least 10m, since a patrol of a care home "
         "takes longer than that"),
        (NIGHT_TABLE.replace('"2h"', '"0m"'), ":3: schedule[0].every must be a positive time"),
        (NIGHT_TABLE.replace('"22:00"', '"22h"'),
         ':4: schedule[0].from should be a local time of day such as "22:00"'),
        (NIGHT_TABLE.replace('"06:00"', '"24:00"'), ":5: schedule[0].to should be"),
        (NIGHT_TABLE.replace('patrol = "night"\n', ""),
         ":1: schedule[0].patrol is missing: name a patrol in the routes folder"),
        (NIGHT_TABLE + "evry = 3\n", ":6: unknown key schedule[0].evry"),
        ("[teleop]\nspeed = 0.3\n\n" + NIGHT_TABLE + NIGHT_TABLE.replace('"night"', '"a b"'),
         ":10: schedule[1].patrol name 'a b' may use only"),
        ("schedule = 3\n", ":1: schedule must be tables, each one [[schedule]]"),
    ],
)  # fmt: skip
def test_a_bad_schedule_is_refused_with_its_line(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SettingsError) as caught:
        load_settings(path)
    assert str(caught.value).startswith(f"{path}:")
    assert f"{path}{message}" in str(caught.value)


def test_the_limits_table_is_read_by_the_names_of_file_limits_fields(tmp_path):
    names = [limit.name for limit in fields(FileLimits)]
    table = "".join(f"{name} = {n + 7}\n" for n, name in enumerate(names))
    path = write(tmp_path, "max_consoles = 8\n[limits]\n" + table)
    settings = load_settings(path)
    assert settings.limits == FileLimits(**{name: n + 7 for n, name in enumerate(names)})
    assert settings.max_consoles == 8
    assert Settings().limits == FileLimits() and Settings().max_consoles == 64


def test_the_control_rate_is_within_the_boards_means(tmp_path):
    for rate in (10, 20, 30):
        assert load_settings(write(tmp_path, f"control_rate = {rate}")).control_rate == rate
    for rate in (9.9, 30.5, 1e6, 0.2):
        with pytest.raises(SettingsError, match=r":1: control_rate must be between 10 and 30 Hz"):
            load_settings(write(tmp_path, f"control_rate = {rate}"))


def test_the_readme_table_gives_every_keys_range_as_checked():
    readme = (Path(__file__).parents[1] / "README.md").read_text()
    section = readme.split("### Settings\n", 1)[1].split("\n### ", 1)[0]
    rows = {}
    for line in section.splitlines():
        if line.startswith("| `"):
            cells = [cell.strip() for cell in line.strip("|").split("|")]
            rows[cells[0].strip("`")] = cells[2]
    for name, span in RANGES.items():
        if name.startswith("limits."):
            assert f"`{name.removeprefix('limits.')}`" in section
            continue
        unit = f" {span.unit}" if span.unit else ""
        assert rows[name].startswith(f"{span.low:g} to {span.high:g}{unit}"), name
    for name, choices in CHOICES.items():
        assert rows[name] == ", ".join(map(str, choices)), name
    assert rows["[limits]"].startswith(f"each 1 to 2^{MAX_LIMIT.bit_length() - 1}, whole")
