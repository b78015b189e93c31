"""Settings files: whatever their bytes, load_settings gives settings or a
SettingsError that names the file, never a traceback (issue 12); and the files made to
hurt (issue 30) are refused through the real command line with exit 2, each within 5 s
and 300 MB of the child's peak memory."""

from __future__ import annotations

import os
import random
from pathlib import Path

import pytest
from hypothesis import given

from giraff_console.settings import SettingsError, load_settings
from tests.fuzz.bounded_run import run_bounded
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
        assert str(error) == (f"{path}:2: teleop.max_speed must be between 0.05 and 1 m/s, "
                              "not 1e+308 m/s")  # fmt: skip
    else:
        raise AssertionError("max_speed = 1e308 loaded")


# Issue 30's bounds on any refusal of a file made to hurt.
SECONDS = 5.0
PEAK_BYTES = 300 * 1024 * 1024
# Longer than any refusal takes on a loaded machine: a child still running then hangs.
HANG_S = 60.0
DEEP = 100_000


def refused_by_the_cli(path: Path) -> tuple[str, float, int]:
    """`giraff-console --config path go kitchen` run to its end: what it said, its CPU
    time and its own peak resident memory in bytes. Fails unless it exits 2 within
    HANG_S, without a traceback.

    CPU time, not the wall clock's: starting Python and the package is 1.3 s of it on an
    idle machine, and the wall clock's share of that grows with whatever else the machine
    runs (beside the other tests, 5 s), which says nothing of the file."""
    finished = run_bounded(path.parent, "--config", str(path), "go", "kitchen", deadline=HANG_S)
    assert finished.status is not None, f"{path.name}: still running after {HANG_S:g} s"
    assert finished.status == 2, finished.said
    assert "Traceback" not in finished.said
    # Starting Python and the package counts too: the bounds are on all of it.
    return finished.said, finished.cpu_seconds, finished.peak_kib * 1024


def nested_arrays(path: Path) -> str:
    path.write_text("speeds = " + "[" * DEEP + "]" * DEEP + "\n")
    return ":1: nested more than 100 levels deep"


def nested_arrays_over_lines(path: Path) -> str:
    path.write_text("# a file of arrays, each on its own line\nspeeds = [\n" + "[\n" * DEEP)
    return ":101: nested more than 100 levels deep"


def nested_inline_tables(path: Path) -> str:
    path.write_text("[teleop]\nspeed = 0.3\nx = " + "{a = " * DEEP + "1" + "}" * DEEP + "\n")
    return ":3: nested more than 100 levels deep"


def a_dotted_key(path: Path) -> str:
    # tomllib makes a table per part, and takes 6 s and 400 MB over 10,000 of them.
    path.write_text("a" + ".a" * DEEP + " = 1\n")
    return ":1: nested more than 100 levels deep"


def a_dotted_table(path: Path) -> str:
    path.write_text('port = "/dev/ttyS0"\n[' + "a." * DEEP + "a]\n")
    return ":2: nested more than 100 levels deep"


def too_large(path: Path) -> str:
    path.write_text("# a comment\n" * 200_000)  # 2.4 MB of nothing that nests
    return ": it holds 2,400,000 bytes, more than the 1,048,576 a settings file may have"


def a_fifo(path: Path) -> str:
    os.mkfifo(path)  # opened for reading, it would wait for a writer that never comes
    return ": it is a named pipe (FIFO), not a regular file"


def a_link_to_dev_zero(path: Path) -> str:
    path.symlink_to("/dev/zero")
    return ": it is a device, not a regular file"


def a_folder(path: Path) -> str:
    path.mkdir()
    return ": it is a folder, not a regular file"


def a_huge_number(path: Path) -> str:
    path.write_text("[limits]\nfile_bytes = " + "9" * 4000 + "\n")
    return ":2: limits.file_bytes must be between 1 and 1099511627776, not a larger number"


BOMBS = (nested_arrays, nested_arrays_over_lines, nested_inline_tables, a_dotted_key,
         a_dotted_table, too_large, a_fifo, a_link_to_dev_zero, a_folder,
         a_huge_number)  # fmt: skip


@pytest.mark.timeout(HANG_S + 30)
@pytest.mark.parametrize("bomb", BOMBS, ids=lambda bomb: bomb.__name__)
def test_a_settings_file_made_to_hurt_is_refused_in_bounds(tmp_path, bomb):
    path = tmp_path / "config.toml"
    where = bomb(path)
    stderr, cpu, peak = refused_by_the_cli(path)
    assert f"giraff-console: {path}{where}" in stderr
    assert cpu < SECONDS, f"{cpu:.1f} s of CPU"
    assert peak < PEAK_BYTES, f"{peak / 2**20:.0f} MB"


@FUZZ
@given(data=file_cases(SEED, one_value_changed))
def test_any_bytes_give_settings_or_a_settings_error(folder, data):
    path = folder / "config.toml"
    path.write_bytes(data)
    try:
        load_settings(path)
    except SettingsError as error:
        assert str(error).startswith(f"{path}:")
