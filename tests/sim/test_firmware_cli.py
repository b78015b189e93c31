"""`giraff-console sim --firmware ...` and the console's `--firmware`, as an operator runs them."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
import serial

from giraff_console.cli.main import build_parser
from giraff_console.data_folders import example_floorplan
from giraff_console.protocol.charger import ChargeStatus, parse_charger
from giraff_console.runtime.board import simulator_url
from tests.conftest import start_sim_process, stop_sim_process


def exchange(port: serial.Serial, command: bytes | None) -> list[str]:
    """Send `command` (None: just listen) and return the lines before the prompt."""
    if command is not None:
        port.write(command + b"\r")
    data = b""
    deadline = time.monotonic() + 5.0
    while not data.endswith(b"OK >\r\n"):
        assert time.monotonic() < deadline, f"no prompt after {data!r}"
        data += port.read(max(1, port.in_waiting))
    return data.decode("ascii").split("\r\n")[:-2]


def test_sim_serves_a_later_board_docked_at_the_floor_plans_start():
    process, path = start_sim_process(
        "--firmware", "later", "--battery", "0.5", "--floorplan", str(example_floorplan())
    )
    try:
        with serial.Serial(path, 115200, timeout=0.2) as port:
            assert exchange(port, None)[-1] == "# Giraf 1.4.226-sim, 2015-09-14"
            reading = parse_charger(exchange(port, b"get charger_data")[0])
            assert (reading.parameter, reading.status) == ("B", ChargeStatus.FAST_CHARGING)
            assert exchange(port, b"get h") == ["I*00000000"]
    finally:
        assert stop_sim_process(process) == 0


@pytest.mark.parametrize("args", [["--battery", "2"], ["--wheel-base", "0"]])
def test_sim_refuses_a_battery_or_wheel_base_out_of_range(args):
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "sim", "--pty", *args],
        capture_output=True, text=True, timeout=20,
    )  # fmt: skip
    assert result.returncode == 2
    assert "--battery must be from 0 to 1" in result.stderr


def test_sim_help_names_the_firmware_profiles(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["sim", "--help"])
    help_text = capsys.readouterr().out
    for word in ("--firmware", "thesis", "later", "giraff-x", "--battery", "--wheel-base"):
        assert word in help_text


@pytest.mark.parametrize(
    ("argv", "firmware"),
    [
        (["--firmware", "later", "sim"], "later"),
        (["sim", "--firmware", "giraff-x"], "giraff-x"),
        (["sim"], None),
        (["--sim", "--firmware", "later"], "later"),
    ],
)
def test_firmware_is_accepted_before_or_after_sim(argv, firmware):
    assert build_parser().parse_args(argv).firmware == firmware


def test_an_unknown_firmware_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--sim", "--firmware", "2015"])
    assert "invalid choice" in capsys.readouterr().err


def test_the_console_asks_the_in_process_simulator_for_its_firmware():
    assert simulator_url(None) == "giraff-sim://"
    assert simulator_url("later") == "giraff-sim://?firmware=later"
    url = simulator_url("giraff-x", virtual_clock=True)
    assert url == "giraff-sim://?clock=virtual&firmware=giraff-x"
    assert serial.serial_for_url(url).board.greeting().startswith(b"# Giraf X2.0.9-sim")


def test_firmware_without_the_simulator_is_a_usage_error():
    result = subprocess.run(
        [sys.executable, "-m", "giraff_console", "--port", "/dev/null", "--firmware", "later"],
        capture_output=True, text=True, timeout=20,
    )  # fmt: skip
    assert result.returncode == 2
    assert "--firmware: only with the simulator (--sim)" in result.stderr
