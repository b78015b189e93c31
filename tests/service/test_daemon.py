"""`giraff-console serve` as it runs: the real daemon in a child process on the built-in
simulator, consoles attached from this process over its socket, and the real CLI in
children of their own (issue 15).

Each test has a runtime folder, and so a socket, of its own; the daemon is ended (SIGTERM,
then SIGKILL) whatever the test does. `--no-landmarks` spares the simulated camera's CPU:
these tests are about who may drive and what outlives a console, not localisation.
"""

from __future__ import annotations

import json
import os
import queue
import re
import shutil
import signal
import socket
import stat
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from giraff_console.camera.shared_frame import SharedFrame
from giraff_console.missions.go_to import GO_JSON_KEYS
from giraff_console.missions.patrol_report import PATROL_JSON_KEYS, STOP_JSON_KEYS
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.deadman import Intent
from giraff_console.robot.loop_events import LoopEvent, MissionChanged, Note
from giraff_console.robot.telemetry import Telemetry
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service import wire
from giraff_console.service.console_hello import Asked, Hello
from giraff_console.service.daemon import Answered, Welcome, daemon_alive
from giraff_console.service.events import Controls, Reply, RoomRenamed, Situation
from giraff_console.service.reattach import Attached, Disconnected, Reattaching
from giraff_console.service.remote import RemoteRobot
from giraff_console.service.runtime_folder import socket_path
from giraff_console.service.transport import parse
from giraff_console.settings import Settings
from tests.planning.scanned_building import write_scanned_plan
from tests.service.daemon_rig import (
    DaemonProcess,
    Heard,
    at_rest,
    distance,
    kill_daemon,
    program,
    run_cli,
    start_daemon,
    stop_daemon,
)

SIM = ("--sim", "--no-landmarks")
CARE_HOME = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"
# Seconds for an answer, an event or a settle, on a loaded 2-core machine.
WAIT_S = 5.0
# Seconds between key repeats: a held arrow key, well inside the deadman's 0.15 s.
REPEAT_S = 0.03
# The runaway rule (design.md): a console that dies at any moment stops the robot
# within 0.3 m at 0.4 m/s (teleop's default speed).
RUNAWAY_M = 0.3
# Virtual seconds from the hang-up to rest: the deadman's repeat timeout (0.15 s), a
# brake from 0.4 m/s at 0.5 m/s^2 (0.8 s) and a few 50 ms ticks of slack.
REST_S = 0.15 + 0.8 + 0.25


@pytest.fixture
def runtime(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A runtime folder of the test's own, short enough for a socket's path, for this
    process (socket_path) and the children alike; and an empty settings folder, so
    that no settings file of the machine's changes the daemon."""
    folder = Path(tempfile.mkdtemp(prefix="gd-", dir="/tmp"))
    (folder / "config").mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(folder / "config"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def serve(runtime: Path) -> Iterator[Callable[..., DaemonProcess]]:
    """Starts `giraff-console serve ARGS`; every daemon started is ended afterwards."""
    started: list[DaemonProcess] = []

    def start(*args: str) -> DaemonProcess:
        daemon = start_daemon(runtime, args, log_name=f"serve-{len(started)}.log")
        started.append(daemon)
        return daemon

    yield start
    for daemon in started:
        stop_daemon(daemon)


@pytest.fixture
def attach() -> Iterator[Callable[..., RemoteRobot]]:
    """Attaches a console to a daemon; every console is hung up afterwards."""
    consoles: list[RemoteRobot] = []

    def console(daemon: DaemonProcess, name: str, take: bool = True) -> RemoteRobot:
        robot = RemoteRobot(daemon.socket, name, take=take)
        consoles.append(robot)
        return robot

    yield console
    for robot in consoles:
        robot.close()


def socket_inodes(pid: int) -> set[int]:
    """The inodes of the sockets process `pid` holds open (all its threads share them)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except FileNotFoundError:  # closed meanwhile
            continue
        found = re.fullmatch(r"socket:\[(\d+)\]", target)
        if found:
            inodes.add(int(found[1]))
    return inodes


def inet_rows(pid: int) -> list[tuple[str, str, str, int]]:
    """Every IPv4/IPv6 TCP, UDP and raw socket in the process's network namespace:
    (table, local address, state, inode)."""
    rows = []
    for table in ("tcp", "tcp6", "udp", "udp6", "udplite", "udplite6", "raw", "raw6"):
        path = Path(f"/proc/{pid}/net/{table}")
        if not path.exists():
            assert table not in ("tcp", "tcp6", "udp", "udp6"), f"no {path} to look in"
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            rows.append((table, fields[1], fields[3], int(fields[9])))
    return rows


def unix_listeners(pid: int) -> dict[int, str]:
    """The listening Unix sockets of the process's namespace: inode -> path."""
    listening = {}
    for line in Path(f"/proc/{pid}/net/unix").read_text().splitlines()[1:]:
        fields = line.split()
        flags, inode = int(fields[3], 16), int(fields[6])
        if flags & 0x10000:  # __SO_ACCEPTCON: listen() was called
            listening[inode] = fields[7] if len(fields) > 7 else ""
    return listening


# -- where it listens -----------------------------------------------------------------


def test_the_socket_is_ours_alone_and_nothing_listens_on_the_network(serve):
    daemon = serve(*SIM)
    info = os.lstat(daemon.socket)
    assert stat.S_ISSOCK(info.st_mode)
    assert stat.S_IMODE(info.st_mode) == 0o600, oct(info.st_mode)
    assert info.st_uid == os.getuid()
    folder = os.lstat(daemon.socket.parent)
    assert stat.S_ISDIR(folder.st_mode)
    assert stat.S_IMODE(folder.st_mode) == 0o700, oct(folder.st_mode)
    assert folder.st_uid == os.getuid()

    held = socket_inodes(daemon.pid)
    # It does hold sockets, one of them listening at its path: else the look below
    # would find nothing to find.
    listeners = unix_listeners(daemon.pid)
    assert [listeners[inode] for inode in held if inode in listeners] == [str(daemon.socket)]
    on_the_network = [row for row in inet_rows(daemon.pid) if row[3] in held]
    assert on_the_network == [], f"the daemon holds network sockets: {on_the_network}"
    assert daemon.alive(), daemon.notes()


# -- who drives -----------------------------------------------------------------------


def test_only_the_holder_drives_and_its_hang_up_stops_the_robot(serve, attach):
    daemon = serve(*SIM)
    holder = attach(daemon, "holder", take=True)
    assert holder.welcome.controls.holder == holder.console
    watcher = attach(daemon, "watcher", take=True)
    assert watcher.welcome.controls.holder == holder.console, "the controls changed hands"
    heard = Heard()
    watcher.subscribe(heard)
    rest = heard.wait_for(Telemetry, at_rest, WAIT_S, what="a snapshot of the robot at rest")

    # The watcher holds its arrow key for a second: refused, and the robot stays put.
    start = heard.mark()
    refusals = []
    until = time.monotonic() + 1.0
    while time.monotonic() < until:
        refusals.append(watcher.execute(c.Press(Intent.FORWARD), timeout=WAIT_S))
        time.sleep(REPEAT_S)
    assert refusals and not any(reply.ok for reply in refusals), refusals
    assert holder.console in refusals[0].text and "holds the controls" in refusals[0].text
    seen = heard.since(start, Telemetry)
    assert len(seen) >= 5, f"only {len(seen)} snapshots in a second"
    assert max(distance(rest.pose, t.pose) for t in seen) < 0.005
    assert not any(t.state is not None and t.state.moving for t in seen)
    # Anyone may stop the robot, holding the controls or not.
    halted = watcher.execute(c.Halt(), timeout=WAIT_S)
    assert halted.ok, halted

    # The holder's key drives it, until it is well under way at full speed.
    until = time.monotonic() + 15.0
    while True:
        reply = holder.execute(c.Press(Intent.FORWARD), timeout=WAIT_S)
        assert reply.ok, reply
        latest = heard.latest(Telemetry)
        assert latest is not None
        if distance(rest.pose, latest.pose) >= 0.45:
            break
        assert time.monotonic() < until, f"the holder's keys moved it only to {latest.pose}"
        time.sleep(REPEAT_S)
    # ... and hangs up with the key held: the last snapshot the watcher had by then is
    # where the hang-up is measured from (if anything, from a little before it).
    hung_up_at = heard.mark()
    before = heard.latest(Telemetry)
    assert before is not None and before.state is not None and before.state.moving
    assert (before.state.speed or 0.0) > 0.35, f"hung up at only {before.state.speed} m/s"
    holder.close()

    stopped = heard.wait_for(Telemetry, at_rest, WAIT_S, since=hung_up_at,
                             what="the robot at rest after the hang-up")  # fmt: skip
    assert before.state is not None and stopped.state is not None
    took = stopped.state.received_at - before.state.received_at
    travelled = distance(before.pose, stopped.pose)
    assert took <= REST_S, f"at rest {took:.2f} s (virtual) after the hang-up"
    assert travelled <= RUNAWAY_M, f"{travelled:.3f} m after the hang-up"
    # ... and stays there.
    time.sleep(0.3)
    last = heard.latest(Telemetry)
    assert last is not None and distance(stopped.pose, last.pose) < 0.005
    # The watcher is told that the controls are free.
    heard.wait_for(Controls, lambda e: e.holder is None and holder.console not in e.consoles,
                   WAIT_S, since=hung_up_at, what="the controls freed")  # fmt: skip
    heard.wait_for(Note, lambda e: holder.console in e.text, WAIT_S, since=hung_up_at,
                   what="a note that the holder left")  # fmt: skip
    assert daemon.alive(), daemon.notes()


def test_a_watcher_that_takes_the_controls_drives_and_the_old_holder_no_longer_does(serve, attach):
    daemon = serve(*SIM)
    holder = attach(daemon, "first", take=True)
    watcher = attach(daemon, "second", take=True)
    heard = Heard()
    holder.subscribe(heard)
    assert watcher.welcome.controls.holder == holder.console

    took = watcher.execute(c.TakeControls(), timeout=WAIT_S)
    assert took.ok, took
    heard.wait_for(Controls, lambda e: e.holder == watcher.console, WAIT_S,
                   what="the controls going to the watcher")  # fmt: skip
    refused = holder.execute(c.Press(Intent.FORWARD), timeout=WAIT_S)
    assert not refused.ok and watcher.console in refused.text, refused
    driven = watcher.execute(c.Press(Intent.FORWARD), timeout=WAIT_S)
    assert driven.ok, driven
    status = holder.execute(c.Status(), timeout=WAIT_S)
    assert f"controls: {watcher.console};" in "\n".join(status.lines), status


def test_a_room_renamed_by_one_console_is_renamed_for_every_console(serve, attach, tmp_path):
    plan = write_scanned_plan(tmp_path)
    daemon = serve(*SIM, "--floorplan", str(plan))
    holder = attach(daemon, "first", take=True)
    watcher = attach(daemon, "second", take=False)
    heard = Heard()
    watcher.subscribe(heard)
    renamed = holder.execute(c.Name("east-room", "kitchen"), timeout=WAIT_S)
    assert renamed.ok and "saved" in renamed.text, renamed
    heard.wait_for(RoomRenamed, lambda e: (e.old, e.new) == ("east-room", "kitchen"), WAIT_S,
                   what="the rename reaching the watcher")  # fmt: skip
    assert "kitchen" in load_floorplan(plan).rooms
    # A console that attaches later reads the saved plan.
    assert "kitchen" in load_floorplan(attach(daemon, "third").welcome.floorplan).rooms


# -- what outlives a console ----------------------------------------------------------


def said(status: Reply, part: str) -> str:
    """The line of a `status` answer about `part` (service/status.py)."""
    return next(line for line in status.lines if line.startswith(f"{part}:"))


def test_a_mission_goes_on_when_the_console_that_started_it_hangs_up(serve, attach):
    daemon = serve(*SIM, "--sim-speed", "16")
    starter = attach(daemon, "starter", take=True)
    heard = Heard()
    starter.subscribe(heard)
    answers = Heard()
    starter.post(c.Go("room-101"), answers)
    started = heard.wait_for(MissionChanged, lambda e: e.running, WAIT_S,
                             what="the mission starting")  # fmt: skip
    starter.close()
    # Its answer may or may not have come before the hang-up; if it did, it was yes.
    assert all(reply.ok for reply in answers.since()), answers.since()

    later = attach(daemon, "later", take=False)
    # Attached after the hang-up: the mission runs on (or, on a slow machine, has already
    # ended, which the status below checks was done, not stopped).
    situation = later.welcome.situation
    assert situation.mission == started.name or situation.last_mission is not None, situation
    # The daemon sees the hang-up within a poll of the starter's connection, and lets go
    # of the controls it held.
    until = time.monotonic() + WAIT_S
    while "starter" in said(later.execute(c.Status(), timeout=WAIT_S), "controls"):
        assert time.monotonic() < until, "the starter's hang-up was never seen"
        time.sleep(0.1)
    assert said(later.execute(c.Status(), timeout=WAIT_S), "controls").startswith("controls: free")
    until = time.monotonic() + 30.0
    while True:
        assert time.monotonic() < until, f"the mission never ended:\n{daemon.notes()}"
        status = later.execute(c.Status(), timeout=WAIT_S)
        assert status.ok, status
        if said(status, "last mission") != "last mission: none":
            break
        time.sleep(0.3)
    assert said(status, "mission") == "mission: none", status.lines
    # The mission's own words on how it ended (an arrival by the odometry alone here).
    ended = said(status, "last mission")
    assert ended.startswith(f"last mission: {started.name}: arrived"), status.lines
    assert daemon.alive(), daemon.notes()


# -- the CLI --------------------------------------------------------------------------


def test_status_json_says_who_holds_the_controls(serve, attach):
    daemon = serve(*SIM)
    operator = attach(daemon, "operator", take=True)
    result = run_cli("status", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert list(report) == STATUS_KEYS, report
    assert report["holder"] == operator.console
    # The status command's own console is attached too, but not reported.
    assert report["consoles"] == [operator.console]
    assert report["mission"] is None and report["last_mission"] is None
    assert report["socket"] == str(daemon.socket)


# The keys of `status --json`, schema 1 (docs/daemon.md): added to, never changed.
STATUS_KEYS = ["schema", "link", "pose", "mission", "battery", "holder", "consoles",
               "last_mission", "recording", "playing", "camera_fps", "socket"]  # fmt: skip


def test_status_says_where_the_robot_is_how_well_known_the_mission_left_and_the_battery(
    serve,
):
    daemon = serve("--sim", "--firmware", "later", "--sim-speed", "4")
    # The later board's charger is read a parameter each half second: all of it soon.
    deadline = time.monotonic() + 2 * WAIT_S
    while True:
        report = json.loads(run_cli("status", "--json").stdout)
        battery = report["battery"]
        if (battery and battery["percent"] is not None) or time.monotonic() > deadline:
            break
        time.sleep(0.3)
    assert list(report) == STATUS_KEYS and report["schema"] == 1
    assert report["link"] == "connected"
    pose = report["pose"]
    assert pose["x"] == pytest.approx(2.0, abs=0.01) and pose["y"] == pytest.approx(7.0, abs=0.01)
    assert pose["sigma_m"] > 0 and pose["basis"] in ("given", "marker")
    assert report["battery"]["percent"] is not None  # the later board has a charger
    assert report["camera_fps"] is not None  # the daemon has a camera to share
    going = subprocess.Popen(program("go", "kitchen"), stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, env=dict(os.environ))  # fmt: skip
    try:
        deadline = time.monotonic() + 3 * WAIT_S
        while True:
            words = run_cli("status")
            if "left, ETA" in words.stdout or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        lines = words.stdout.splitlines()
        assert [line.split(":")[0] for line in lines[:7]] == [
            "link", "pose", "mission", "battery", "camera", "controls", "last mission"]  # fmt: skip
        assert lines[2].startswith("mission: go kitchen") and "left, ETA" in lines[2], lines
        assert "±" in lines[1] and "%" in lines[3], lines
        moving = json.loads(run_cli("status", "--json").stdout)["mission"]
        assert moving["name"] == "go kitchen" and moving["left_m"] > 0 and moving["eta_s"] > 0
    finally:
        going.terminate()
        going.wait(timeout=WAIT_S)
    assert daemon.alive()


def test_watch_json_streams_the_daemons_events_a_json_object_a_line(serve):
    # 16 times real time, as the other tests here whose go is only waited for: what is
    # looked at is the events the whole go sends, which the pipe keeps in order.
    serve(*SIM, "--sim-speed", "16")
    watching = subprocess.Popen(
        program("watch", "--json"), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, env=dict(os.environ),
    )  # fmt: skip
    lines: queue.Queue[str] = queue.Queue()
    reader = threading.Thread(target=lambda: [lines.put(line) for line in watching.stdout])
    reader.start()
    events: list[dict] = []
    try:
        # Attached once the first snapshot comes through.
        while not any(event["type"] == "Telemetry" for event in events):
            events.append(json.loads(lines.get(timeout=WAIT_S)))
        assert run_cli("go", "room-101").returncode == 3
        while not any(event["type"] == "GoReported" for event in events):
            events.append(json.loads(lines.get(timeout=3 * WAIT_S)))
    finally:
        watching.send_signal(signal.SIGINT)
        watching.wait(timeout=WAIT_S)
        reader.join(WAIT_S)
    assert watching.returncode == 0, watching.stderr.read()
    ended = [event for event in events if event["type"] == "MissionChanged"
             and not event["running"]]  # fmt: skip
    assert ended and ended[-1]["end"]["outcome"]["value"] == "ARRIVED_UNVERIFIED"
    report = next(event["report"] for event in events if event["type"] == "GoReported")
    assert report["room"] == "room-101"
    # The loop's own polls are left out: the snapshots say what they read.
    assert not any(event["type"] == "Exchange" and event["automatic"] for event in events)


def test_status_without_a_daemon_exits_3_and_says_how_to_start_one(runtime):
    result = run_cli("status", "--json")
    assert result.returncode == 3, (result.stdout, result.stderr)
    assert result.stdout == ""
    assert "giraff-console serve" in result.stderr and str(socket_path()) in result.stderr


def test_stop_daemon_ends_the_daemon_and_removes_its_socket(serve):
    daemon = serve(*SIM)
    result = run_cli("stop", "--daemon")
    assert result.returncode == 0, result.stderr
    assert "the daemon is ending" in result.stderr
    # Ended by the request, not a signal: 0 (cli/serve.py run_serve); within the 5 s
    # that systemd gives it before it kills it (docs/giraff-console.service).
    assert daemon.process.wait(timeout=5.0) == 0, daemon.notes()
    assert not daemon.socket.exists()
    again = run_cli("status")
    assert again.returncode == 3, again.stderr


def test_go_asks_the_running_daemon_and_reports_the_end(serve):
    daemon = serve(*SIM, "--sim-speed", "16")
    result = run_cli("go", "room-101")
    # No markers: arrived by the odometry, said to be unconfirmed, exit 3, as `go` alone.
    assert result.returncode == 3, f"{result.stdout}\n{result.stderr}\n{daemon.notes()}"
    assert result.stdout.splitlines()[-1].startswith("go room-101: arrived by the odometry")
    assert f"asking the daemon at {daemon.socket}" in result.stderr
    # The daemon drove it, and keeps how it ended.
    status = run_cli("status", "--json")
    assert status.returncode == 0, status.stderr
    last = json.loads(status.stdout)["last_mission"]
    assert (last["name"], last["why"], last["outcome"]) == (
        "go room-101", "done", "arrived_unverified")  # fmt: skip


def test_go_json_says_the_same_keys_with_and_without_a_daemon(serve):
    """Issue 26: through the daemon `go --json` printed three keys, on its own seventeen.
    Both now ask the same service, which reports the go (GoReport) the same way."""
    alone = run_cli("go", "room-101", "--json", *SIM, "--sim-speed", "16")
    assert alone.returncode == 3, alone.stderr
    serve(*SIM, "--sim-speed", "16")
    asked = run_cli("go", "room-101", "--json")
    assert asked.returncode == 3, asked.stderr
    here, there = json.loads(alone.stdout), json.loads(asked.stdout)
    assert list(here) == list(there) == list(GO_JSON_KEYS)
    # The same go in the same simulated building: the same end, measured the same way.
    for report in (here, there):
        assert (report["outcome"], report["room"], report["arrived"]) == (
            "arrived_unverified", "room-101", False)  # fmt: skip
        assert report["pose_true"] is not None and report["error_m"] < 0.05


def test_a_patrol_asked_of_the_daemon_by_its_files_path_ends_and_says_how(serve, tmp_path):
    """Issue 26's review: the daemon's patrol is named by its file's name, and a path
    is the daemon's to read: the command followed a mission named "patrol NAME" that
    never came, and waited for ever."""
    patrol = tmp_path / "short.patrol.yaml"
    patrol.write_text("rounds: 1\nstops:\n  - {room: room-101}\n")
    serve(*SIM, "--sim-speed", "16")
    result = run_cli("patrol", str(patrol), "--json")
    # No markers: the one stop reached by the odometry alone, unconfirmed: exit 3.
    assert result.returncode == 3, f"{result.stdout}\n{result.stderr}"
    said = json.loads(result.stdout.splitlines()[-1])
    # The patrol's name, as without a daemon: its file's, however the file was named.
    assert (said["patrol"], said["outcome"]) == ("short", "arrived_unverified")


def _patrol_lines(result: subprocess.CompletedProcess[str]) -> list[str]:
    assert result.returncode == 3, f"{result.stdout}\n{result.stderr}"
    return result.stdout.splitlines()


def _shape(line: str) -> str:
    """A line of `patrol`'s words with its figures taken out: what it says, not how far."""
    return re.sub(r"-?\d+(\.\d+)?", "N", line)


def test_patrol_prints_the_same_lines_with_and_without_a_daemon(serve, tmp_path):
    """Issue 26: through the daemon `patrol --json` printed one line of four keys; on
    its own a line for each stop and one for the patrol. Both now ask the same service,
    which reports each stop as it ends and the patrol at its end, the same way."""
    patrol = tmp_path / "there-and-back.patrol.yaml"
    patrol.write_text("rounds: 1\nstops:\n  - {room: room-101}\n  - {room: dock}\n")
    alone = _patrol_lines(run_cli("patrol", str(patrol), "--json", *SIM, "--sim-speed", "inf"))
    alone_words = _patrol_lines(run_cli("patrol", str(patrol), *SIM, "--sim-speed", "inf"))
    serve(*SIM, "--sim-speed", "16")
    asked = _patrol_lines(run_cli("patrol", str(patrol), "--json"))
    asked_words = _patrol_lines(run_cli("patrol", str(patrol)))
    here, there = [json.loads(line) for line in alone], [json.loads(line) for line in asked]
    assert len(here) == len(there) == 3, (alone, asked)
    for mine, theirs in zip(here, there, strict=True):
        assert list(mine) == list(theirs)
    assert list(here[0]) == list(STOP_JSON_KEYS) and list(here[-1]) == list(PATROL_JSON_KEYS)
    # The same patrol in the same simulated building: the same stops, ended the same way.
    for lines in (here, there):
        *stops, summary = lines
        assert [(s["stop"], s["room"], s["outcome"]) for s in stops] == [
            (1, "room-101", "arrived_unverified"), (2, "dock", "arrived_unverified")]  # fmt: skip
        assert all(s["pose_true"] is not None and s["error_m"] < 0.05 for s in stops)
        assert (summary["patrol"], summary["outcome"], summary["stops"], summary["failed"]) == (
            "there-and-back", "arrived_unverified", 2, 0)  # fmt: skip
    # In words too: a line a stop and one for the patrol, said alike.
    assert [_shape(line) for line in alone_words] == [_shape(line) for line in asked_words]
    assert len(alone_words) == 3 and alone_words[-1].startswith("patrol there-and-back: done")


# -- what does not disturb it ---------------------------------------------------------


def test_a_second_serve_fails_and_leaves_the_first_alone(serve, attach):
    daemon = serve(*SIM)
    before = os.lstat(daemon.socket)
    second = run_cli("serve", *SIM)
    assert second.returncode == 2, second.stderr
    assert "already running" in second.stderr
    after = os.lstat(daemon.socket)
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)
    assert daemon.alive(), daemon.notes()
    console = attach(daemon, "after", take=False)
    assert console.execute(c.Status(), timeout=WAIT_S).ok


class RawConsole:
    """A bare connection to the daemon: any bytes out, its messages in, one by one."""

    def __init__(self, path: Path) -> None:
        self.socket = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.socket.settimeout(WAIT_S)
        self.socket.connect(str(path))
        self._buffer = b""

    def send(self, message: object) -> None:
        line = json.dumps(wire.encode(message), separators=(",", ":")).encode() + b"\n"
        self.socket.sendall(line)

    def receive_until(self, found: Callable[[object], bool]) -> object:
        """The daemon's messages until one that is `found`; fails after WAIT_S."""
        deadline = time.monotonic() + WAIT_S
        while True:
            while b"\n" in self._buffer:
                line, self._buffer = self._buffer.split(b"\n", 1)
                message = wire.decode(json.loads(line))
                if found(message):
                    return message
            self.socket.settimeout(max(deadline - time.monotonic(), 0.01))
            chunk = self.socket.recv(65536)
            assert chunk, "the daemon hung up"
            assert time.monotonic() < deadline, "nothing like it came"
            self._buffer += chunk


def test_garbled_lines_do_not_end_the_daemon(serve, attach):
    daemon = serve(*SIM)
    # Garbled instead of a hello: told so, in the protocol's words, and closed.
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as raw:
        raw.settimeout(WAIT_S)
        raw.connect(str(daemon.socket))
        raw.sendall(b"not json\n")
        told = b""
        while chunk := raw.recv(65536):
            told += chunk
        refused = parse(told.rstrip(b"\n"))
        assert isinstance(refused, Answered) and not refused.reply.ok
        assert refused.reply.text == "not understood: a line that is not JSON (at byte 0)"
    # Garbled after a hello: answered "not understood", and the connection goes on.
    raw = RawConsole(daemon.socket)
    with raw.socket:
        raw.send(Hello("raw", take=False))
        raw.receive_until(lambda m: isinstance(m, Welcome))
        raw.socket.sendall(b"not json\n" + b'{"no": "such type"}\n')
        for _ in range(2):
            refused = raw.receive_until(lambda m: isinstance(m, Answered))
            assert isinstance(refused, Answered) and refused.number == -1
            assert not refused.reply.ok and "not understood" in refused.reply.text
        raw.send(Asked(7, c.Status()))
        answered = raw.receive_until(lambda m: isinstance(m, Answered))
        assert isinstance(answered, Answered) and answered.number == 7 and answered.reply.ok
    assert daemon.alive(), daemon.notes()
    console = attach(daemon, "after", take=True)
    assert console.welcome.controls.holder == console.console
    assert console.execute(c.Status(), timeout=WAIT_S).ok


def test_status_after_the_daemon_was_killed_does_not_say_there_is_no_socket(serve):
    # Killed outright, the daemon cannot remove its socket: the file stays, refusing.
    daemon = serve(*SIM)
    kill_daemon(daemon)
    assert daemon.socket.exists()
    result = run_cli("status")
    assert result.returncode == 3, result.stderr
    assert "giraff-console serve" in result.stderr
    # Bug: attach_commands._attach says "no socket at PATH" for any daemon not there,
    # although the socket is at PATH (transport.NoDaemon's own reason is dropped).
    assert "no socket" not in result.stderr, result.stderr


def test_status_shows_a_mission_running_or_how_it_ended_never_neither():
    """What `status` answers (RobotService.situation) as a mission ends. In process, on
    a virtual clock, the loop stepped by hand: a listener looks at the situation each
    time the loop speaks, as a `status` from another console may at any moment."""
    robot = Robot(RobotOptions(floorplan=CARE_HOME, landmarks=False), Settings(), CARE_HOME)
    control, clock, service = robot.control, robot.control.clock, robot.service
    seen: list[tuple[LoopEvent, Situation]] = []
    control.subscribe(lambda event: seen.append((event, service.situation())))

    def run(ticks: int) -> None:
        for _ in range(ticks):
            control.tick()
            clock.advance(control.period)

    try:
        run(3)
        assert service.execute(c.Go("room-101")).ok
        going = len(seen)
        run(5)
        assert service.situation().mission is not None
        assert service.execute(c.StopMission()).ok
        run(3)
    finally:
        robot.close()
    assert service.situation().last_mission is not None
    neither = [event for event, situation in seen[going:]
               if situation.mission is None and situation.last_mission is None]  # fmt: skip
    # ControlLoop._end_mission once forgot the mission, stopped the robot (an exchange
    # with the board, up to its timeout) and made its note, and only then told
    # MissionChanged, which is when RobotService learns how it ended.
    said = [getattr(event, "command", None) or getattr(event, "text", None) or event
            for event in neither]  # fmt: skip
    assert said == [], f"the situation showed no mission and no last one during {said}"


def test_a_console_told_the_daemon_has_gone_only_when_it_has(serve, attach):
    # The lock says it: held while the daemon lives, let go with its last breath.
    daemon = serve(*SIM)
    console = attach(daemon, "watching", take=False)
    assert daemon_alive(daemon.socket)
    kill_daemon(daemon)
    deadline = time.monotonic() + WAIT_S
    while console.gone is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not daemon_alive(daemon.socket)
    assert console.gone is not None and console.gone.startswith("the daemon has gone")


# -- a console through the daemon's restarts ------------------------------------------


def _next(heard: queue.Queue, kind: type, timeout: float):
    """The next event of `kind` heard within `timeout` seconds, and when; the test fails
    without one."""
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        try:
            event = heard.get(timeout=left)
        except queue.Empty:
            break
        if isinstance(event, kind):
            return event, time.monotonic()
    raise AssertionError(f"no {kind.__name__} in {timeout:g} s")


def test_an_attached_console_sees_the_daemon_go_and_attaches_again_by_itself(serve):
    """Issue 26: a daemon stopped left its console showing a live-looking snapshot, every
    key answered "the daemon has gone", for ever. Now: Disconnected within a second of
    the daemon's end, requests refused meanwhile, and attached again, holding the
    controls, within 5 s of a daemon's start."""
    daemon = serve(*SIM)
    heard: queue.Queue = queue.Queue()
    first = RemoteRobot(daemon.socket, "console reattach", take=True)
    robot = Reattaching(first, lambda: RemoteRobot(socket_path(), "console reattach"))
    robot.subscribe(heard.put)
    try:
        assert run_cli("stop", "--daemon").returncode == 0
        daemon.process.wait(timeout=WAIT_S)
        ended = time.monotonic()
        _, told = _next(heard, Disconnected, WAIT_S)
        assert told - ended <= 1.0
        refused: queue.Queue = queue.Queue()
        robot.post(c.Press(Intent.FORWARD), refused.put)
        assert not refused.get(timeout=WAIT_S).ok
        starting = time.monotonic()
        again = serve(*SIM)
        back, at = _next(heard, Attached, WAIT_S + 5.0)
        assert at - starting <= 5.0
        assert back.welcome.controls.holder == back.welcome.console  # asked for, as at start
        answered: queue.Queue = queue.Queue()
        robot.post(c.Status(), answered.put)
        assert answered.get(timeout=WAIT_S).ok
        assert again.alive()
    finally:
        robot.close()


# -- the camera, for consoles in other processes ----------------------------------------


def test_an_attached_console_that_shows_the_camera_gets_its_frames_with_overlays(serve, attach):
    """Issue 26: the attached console was blind ("cam -"). One that asks (c.View) gets
    the daemon's camera, processed (FAST corners, markers) and encoded small, at the
    camera's rate; one that has not asked gets none."""
    daemon = serve("--sim")
    watcher, other = attach(daemon, "watcher"), attach(daemon, "other", take=False)
    frames: queue.Queue[SharedFrame] = queue.Queue()
    unasked: list[SharedFrame] = []
    watcher.subscribe(lambda event: frames.put(event) if isinstance(event, SharedFrame) else None)
    other.subscribe(lambda event: unasked.append(event) if isinstance(event, SharedFrame) else None)
    assert watcher.execute(c.View(on=True), timeout=WAIT_S).ok
    frames.get(timeout=WAIT_S)  # the first
    started, counted, last = time.monotonic(), 0, None
    while time.monotonic() - started < 3.0:
        last = frames.get(timeout=WAIT_S)
        counted += 1
    assert counted / (time.monotonic() - started) >= 8.0
    assert last is not None and last.size == (800, 600) and last.fps >= 8.0
    assert last.keypoints is not None and last.markers == (16,)  # FAST on, marker 16 seen
    image = cv2.imdecode(np.frombuffer(last.jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[1] == 320 and len(last.jpeg) < 64 * 1024  # small: scaled, encoded
    assert unasked == []
    assert watcher.execute(c.View(on=False), timeout=WAIT_S).ok
    time.sleep(0.5)
    while not frames.empty():
        frames.get_nowait()
    time.sleep(0.5)
    assert frames.empty()  # no frames once it stopped asking
