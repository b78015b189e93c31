"""The `giraff-console` command line, run as an operator would run it."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from giraff_console import __version__
from tests.conftest import start_sim_process, stop_sim_process


def run(*args: str, timeout: float = 20) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "giraff_console", *args],
        capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("args", "expected"),
    [([], "simulator"), (["sim"], "pseudo-terminal"), (["send"], "COMMAND")],
)
def test_every_command_explains_itself(args, expected):
    result = run(*args, "--help")
    assert result.returncode == 0
    assert expected in result.stdout


# What a command loads only when it runs: numpy, OpenCV, scipy and networkx for the robot
# and its plans, Textual (and rich) for the screen, PyYAML for files (issue 26, item 6).
HEAVY = ("numpy", "cv2", "scipy", "networkx", "textual", "rich", "yaml", "ruckig", "mcap")
PARSE_ONLY = f"""
import sys
from giraff_console.cli.main import build_parser
parser = build_parser()
parser.format_help()
try:
    parser.parse_args(["--version"])
except SystemExit:
    pass
print("loaded:", *(name for name in {HEAVY!r} if name in sys.modules))
"""


def test_version_and_help_load_none_of_the_heavy_libraries():
    # Every command used to pay 0.8 s of CPU for them before reading its arguments.
    result = subprocess.run([sys.executable, "-c", PARSE_ONLY], capture_output=True,
                            text=True, timeout=60)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [f"giraff-console {__version__}", "loaded:"]


# What `giraff-console stop` must not load (issue 30, item 3): the robot, the requests'
# types, the other commands, and the libraries they bring (each tens of milliseconds, more
# on a loaded PC). pyserial is the package's own (giraff_console/__init__.py teaches it
# the simulator's URLs).
STOP_HEAVY = (
    "numpy", "cv2", "scipy", "textual", "rich", "yaml",
    "giraff_console.robot", "giraff_console.link", "giraff_console.service.commands",
    "giraff_console.service.console_hello", "giraff_console.cli.main",
    # Nor, typed as meant, its parser or our file helpers (cli/stop.py, launch.py).
    "argparse", "shutil", "giraff_console.private_files",
)  # fmt: skip
STOP_ALONE = """
import sys
sys.argv = ["giraff-console", "stop"]
from giraff_console.launch import main
code = main()
print("exit", code)
print("loaded:", *(name for name in {heavy!r} if name in sys.modules))
"""


def test_stop_loads_neither_the_robot_nor_the_other_commands(tmp_path: Path) -> None:
    env = {**os.environ, "XDG_RUNTIME_DIR": str(tmp_path)}  # no daemon there
    result = subprocess.run(
        [sys.executable, "-c", STOP_ALONE.format(heavy=STOP_HEAVY)],
        capture_output=True, text=True, timeout=60, env=env,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["exit 3", "loaded:"]
    assert "no socket file" in result.stderr


@pytest.mark.parametrize("before", [[], ["--config", "none.toml"]])
def test_stop_with_no_daemon_says_so_either_way(before: list[str], tmp_path: Path) -> None:
    """Alone (its own module, launch.py) or after the full command line's options
    (main.py): the same stop, the same words."""
    env = {**os.environ, "XDG_RUNTIME_DIR": str(tmp_path)}
    result = subprocess.run([sys.executable, "-m", "giraff_console", *before, "stop"],
                            capture_output=True, text=True, timeout=60, env=env)  # fmt: skip
    assert result.returncode == 3, result.stderr
    assert "no giraff-console daemon" in result.stderr
    assert "Traceback" not in result.stderr


def test_a_stop_waiting_on_a_silent_daemon_ends_at_ctrl_c(tmp_path: Path) -> None:
    """Started with the signals blocked (as a console's threads have them), a stop that
    waits for an answer still ends at Ctrl-C, at once and without a traceback."""
    folder = tmp_path / "giraff-console"
    folder.mkdir(mode=0o700)
    silent = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    silent.bind(str(folder / "robot.sock"))
    silent.listen()
    blocked = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
    env = {**os.environ, "XDG_RUNTIME_DIR": str(tmp_path)}
    with silent:
        stop = subprocess.Popen(
            [sys.executable, "-m", "giraff_console", "stop"], env=env,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            preexec_fn=lambda: signal.pthread_sigmask(signal.SIG_BLOCK, blocked),
        )  # fmt: skip
        try:
            silent.settimeout(30)
            connection, _ = silent.accept()  # the stop has asked, and waits
            with connection:
                stop.send_signal(signal.SIGINT)
                started = time.monotonic()
                _, errors = stop.communicate(timeout=3)  # its own timeout is 5 s
                took = time.monotonic() - started
        finally:
            stop.kill()
            stop.wait(10)
    assert stop.returncode == 128 + signal.SIGINT, errors
    assert took < 2, took
    assert "interrupted before the daemon answered" in errors
    assert "Traceback" not in errors


def test_send_without_a_port_uses_the_built_in_simulator():
    result = run("send", "get bulk_data", "set v 0.3", "get v")
    assert result.returncode == 0, result.stderr
    out = result.stdout.splitlines()
    assert out[0] == "> get bulk_data"
    assert [line.split()[0] for line in out[1:9]] == [
        "cang", "cdis", "gvr", "tilt_angle_from_home", "imdl", "imdr", "cvg", "mode",
    ]  # fmt: skip
    assert out[-2:] == ["> get v", "  0.30000"]


def test_send_shows_mode_bits_by_name():
    result = run("send", "set r 1", "set mode 0", "set v 0.3", "set a 0.5", "set vg 0",
                 "set p 0.2", "get bulk_data")  # fmt: skip
    assert "128 (MOVING)" in result.stdout


def test_a_refused_command_is_reported_without_a_traceback():
    result = run("send", "--unsafe", "get nonsense")
    assert result.returncode == 1
    assert "board error: Unknown name: nonsense" in result.stdout
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("command", ["set v fast", "get v\rset p 9", "set v 1 2"])
def test_malformed_commands_are_refused_before_anything_is_sent(command):
    result = run("send", command)
    assert result.returncode == 1
    assert result.stderr.startswith("giraff-console: ")
    assert "Traceback" not in result.stderr


def test_a_missing_port_is_a_clear_link_error():
    result = run("send", "--port", "/dev/no-such-giraff", "get v")
    assert result.returncode == 3
    assert "cannot open /dev/no-such-giraff" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sim_prints_only_its_path_first_and_stops_cleanly_on_signals(sig):
    process, path = start_sim_process("--imperfect", "--seed", "3")
    assert path.startswith("/dev/pts/")
    assert stop_sim_process(process, sig) == 0
    assert "Traceback" not in process.stderr.read()


def test_console_script_is_installed():
    from importlib.metadata import entry_points

    scripts = {ep.name: ep.value for ep in entry_points(group="console_scripts")}
    # Through launch.py, which blocks the stop signals before any thread can start.
    assert scripts.get("giraff-console") == "giraff_console.launch:main"


def test_floorplan_landmarks_places_and_prints_from_the_shell(tmp_path):
    help_text = run("floorplan", "landmarks", "--help").stdout
    assert "--every M" in help_text and "--print DIR" in help_text and "--size M" in help_text
    plan = tmp_path / "plan.yaml"
    room = "{at: [2, 1], outline: [[0, 0], [4, 0], [4, 2], [0, 2]]}"
    plan.write_text(f"name: x\nrooms:\n  a: {room}\ndoors: []\n")
    placed = run("floorplan", "landmarks", str(plan))
    assert placed.returncode == 0, placed.stderr
    assert (
        "placed 2 markers (0 beside doorways, 2 along walls, 0 for rooms' stops)" in placed.stdout
    )
    printed = run("floorplan", "landmarks", str(plan), "--print", str(tmp_path / "pages"))
    assert printed.returncode == 0, printed.stderr
    assert sorted(p.name for p in (tmp_path / "pages").iterdir()) == [
        "marker-000.png", "marker-001.png", "markers.pdf"
    ]  # fmt: skip


def test_every_outcome_has_an_exit_code_and_help_says_each_code():
    """Issue 26: exit codes per outcome, listed in --help: a new Outcome without a code,
    or a code --help does not mention, fails here."""
    from giraff_console.cli.exit_codes import EXIT_HELP
    from giraff_console.cli.outcome_codes import EXIT_CODES
    from giraff_console.robot.mission import Outcome

    assert set(EXIT_CODES) == set(Outcome)
    for code in set(EXIT_CODES.values()) | {2}:
        assert f" {code} " in f" {EXIT_HELP}", code
