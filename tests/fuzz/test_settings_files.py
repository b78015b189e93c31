"""Settings files: whatever their bytes, load_settings gives settings or a
SettingsError that names the file, never a traceback (issue 12)."""

from __future__ import annotations

import random

from hypothesis import given

from giraff_console.settings import SettingsError, load_settings
from tests.fuzz.inputs import FUZZ, file_cases

# Every key settings.py documents, at its default.
SEED = b"""\
port = "/dev/ttyS0"
power_line = "dtr"
timeout = 1.0
control_rate = 20
robot_radius = 0.3

[teleop]
speed = 0.4
max_speed = 0.4
accel = 0.5
turn_rate = 45
grace = 0.7
repeat_timeout = 0.15
undock_distance = 0.25

[motion]
v_max = 0.4
a_max = 0.5
j_max = 1.0
lateral_accel = 0.3
door_speed = 0.3
sensing_range = 1.5
"""
# TOML values that are numbers out of range, NaN, or of the wrong type.
TOML_VALUES = (
    "nan", "inf", "-inf", "+nan", "1e308", "-1e308", "1.7976931348623157e308", "5e-324",
    "9223372036854775807", "-9223372036854775808", "0", "-0.0", "-1", "0x7fffffff", "true",
    '"0.4"', "''", "[1, 2]", "{a = 1}", "1979-05-27", "07:32:00", '"\\u0000"',
)  # fmt: skip


def one_value_changed(rng: random.Random) -> bytes:
    lines = SEED.decode().split("\n")
    for _ in range(rng.randint(1, 3)):
        i = rng.choice([i for i, line in enumerate(lines) if " = " in line])
        key = lines[i].split(" = ")[0]
        lines[i] = f"{key} = {rng.choice(TOML_VALUES)}"
    return "\n".join(lines).encode()


def test_the_seed_loads(folder):
    path = folder / "seed.toml"
    path.write_bytes(SEED)
    assert load_settings(path).teleop.turn_rate == 45


def test_a_speed_of_1e308_is_refused_naming_the_key(folder):
    path = folder / "huge.toml"
    path.write_bytes(b"[teleop]\nmax_speed = 1e308\n")
    try:
        load_settings(path)
    except SettingsError as error:
        assert str(error) == f"{path}: teleop.max_speed is 1e+308, out of range"
    else:
        raise AssertionError("max_speed = 1e308 loaded")


@FUZZ
@given(data=file_cases(SEED, one_value_changed))
def test_any_bytes_give_settings_or_a_settings_error(folder, data):
    path = folder / "config.toml"
    path.write_bytes(data)
    try:
        load_settings(path)
    except SettingsError as error:
        assert str(error).startswith(f"{path}:")
