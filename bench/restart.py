"""Benchmark: a daemon killed mid-`go` and started again never drives from the pose it
assumed (issue 25, item 0).

The board is simulated in another process (`giraff-console sim --pty --imperfect`),
with a camera served beside it (`sim --camera`) and its true pose logged (`--pose-log`),
which nothing but this benchmark reads. The daemon drives it over the pty as it would a
real board: `serve --port PTY --camera unix:SOCKET --calibration FILE`, started the
first time with `--at dock` (the operator put the robot there). Then, for each kind:

- go: `go kitchen` through the daemon; killed with SIGKILL a few metres on (as a crash
  would), started again without `--at` (as systemd's Restart=on-failure would), and
  `go kitchen` typed again;
- patrol: the same kill, and the daemon started again with a patrol scheduled a minute
  later (a `[[schedule]]` table), which runs by itself;
- no-camera: the same kill, the daemon started again without a camera, and `go kitchen`
  typed: nothing can confirm the pose, so nothing may drive.

Measured against the true pose: how far the robot ran on after the kill (the runaway
rule's 0.3 m), how far it travelled while its pose was unconfirmed after the restart
(until the daemon's log says a marker found it; the look for a marker turns on the spot
and drives nowhere), every claimed arrival's distance from its goal (none may be more
than 0.10 m off), and what each client was told.

Usage: python bench/restart.py [--kinds go,patrol,no-camera] [--seeds 1,2] [--save FILE]
"""

from __future__ import annotations

import argparse
import datetime as dt
import itertools
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from giraff_console.planning.floorplan import load_floorplan

PLAN = Path(__file__).resolve().parents[1] / "giraff_console/floorplans/care-home.yaml"
GOAL = "kitchen"
# The patrol the schedule starts after the restart: a room, then back to the dock.
PATROL = ["nurse-station", "room-101", "dock"]
# How far into the first `go` the daemon is killed, metres of true travel, by seed.
KILL_AFTER_M = {1: 3.0, 2: 6.5, 3: 11.0, 4: 2.0}
WITHIN_M = 0.10
START_TIMEOUT_S = 20.0
MISSION_TIMEOUT_S = 400.0
FOUND = "found by marker"


@dataclass
class Result:
    kind: str
    seed: int
    run_on_m: float = math.nan  # after the kill, from the true pose
    killed_client_said: str = ""
    unverified_travel_m: float = math.nan  # true travel from the restart to the first fix
    found_after_s: float | None = None
    claims: list[dict] = field(default_factory=list)  # each claimed arrival and its error
    outcomes: list[str] = field(default_factory=list)
    told: str = ""
    problem: str | None = None


def program(*args: str) -> list[str]:
    return [sys.executable, "-m", "giraff_console", *args]


def truth(path: Path) -> list[tuple[float, float, float, bool]]:
    rows = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 5:
            rows.append((float(parts[0]), float(parts[1]), float(parts[2]), parts[4] == "1"))
    return rows


def travel(rows: list[tuple[float, float, float, bool]], since: float, until: float) -> float:
    inside = [(x, y) for t, x, y, _ in rows if since <= t <= until]
    return sum(math.dist(a, b) for a, b in itertools.pairwise(inside))


def at(rows: list[tuple[float, float, float, bool]], moment: float) -> tuple[float, float]:
    before = [row for row in rows if row[0] <= moment] or rows[:1]
    return before[-1][1], before[-1][2]


def wait_for(test: Callable[[], object], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not test():
        if time.monotonic() > deadline:
            raise TimeoutError(f"no {what} in {timeout:.0f} s")
        time.sleep(0.05)


class Daemon:
    """`giraff-console serve` with its log, started and waited on; the log is watched
    for the first time a marker found the robot (its lines carry no times)."""

    def __init__(self, env: dict[str, str], log: Path, *args: str,
                 config: Path | None = None) -> None:  # fmt: skip
        self.log = log
        self.first_fix: float | None = None
        settings = ["--config", str(config)] if config is not None else []
        with log.open("wb") as out:
            self.process = subprocess.Popen(
                program(*settings, "serve", *args),
                stdout=subprocess.DEVNULL,
                stderr=out,
                env=env,
                start_new_session=True,
            )
        self.started = time.monotonic()
        self._watcher = threading.Thread(target=self._watch, daemon=True)
        self._watcher.start()
        wait_for(lambda: "serving the robot" in self.text() or self.process.poll() is not None,
                 START_TIMEOUT_S, "daemon")  # fmt: skip
        if self.process.poll() is not None:
            raise OSError(f"the daemon ended at once: {self.text().strip()[-300:]}")

    def _watch(self) -> None:
        while self.process.poll() is None and self.first_fix is None:
            if FOUND in self.text():
                self.first_fix = time.monotonic()
            time.sleep(0.02)

    def text(self) -> str:
        return self.log.read_text(errors="replace")

    def kill(self) -> float:
        self.process.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        self.process.wait(timeout=10)
        return killed

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)


def scenario(kind: str, seed: int, folder: Path) -> Result:
    result = Result(kind, seed)
    for name in ("run", "data", "config"):
        (folder / name).mkdir(mode=0o700, parents=True, exist_ok=True)
    env = os.environ | {"XDG_RUNTIME_DIR": str(folder / "run"),
                        "XDG_DATA_HOME": str(folder / "data"),
                        "XDG_CONFIG_HOME": str(folder / "config")}  # fmt: skip
    socket_path, log = folder / "run" / "camera.sock", folder / "truth.log"
    sim = subprocess.Popen(program("sim", "--pty", "--floorplan", str(PLAN), "--camera",
                                   str(socket_path), "--pose-log", str(log), "--imperfect",
                                   "--seed", str(seed)),
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                           env=env, start_new_session=True)  # fmt: skip
    daemons: list[Daemon] = []
    try:
        assert sim.stdout is not None
        pty = sim.stdout.readline().strip()
        camera = ["--camera", f"unix:{socket_path}", "--calibration",
                  f"{socket_path}.calibration.yaml"]  # fmt: skip
        robot = ["--port", pty, "--floorplan", str(PLAN)]
        daemons.append(Daemon(env, folder / "serve-1.log", *robot, *camera, "--at", "dock"))
        client = subprocess.Popen(program("go", GOAL, "--json"), stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=env)  # fmt: skip
        wait_for(lambda: log.exists() and travel(truth(log), 0, math.inf) >= KILL_AFTER_M.get(
            seed, 4.0), MISSION_TIMEOUT_S, "travel before the kill")  # fmt: skip
        killed = daemons[0].kill()
        _, told = client.communicate(timeout=20)
        result.killed_client_said = told.strip().splitlines()[-1] if told.strip() else ""
        wait_for(lambda: not truth(log)[-1][3], 10, "rest after the kill")
        time.sleep(1.0)
        rows = truth(log)
        result.run_on_m = travel(rows, killed, math.inf)
        options = [*robot] + ([] if kind == "no-camera" else camera)
        config = schedule(folder) if kind == "patrol" else None
        restarted = time.monotonic()
        daemon = Daemon(env, folder / "serve-2.log", *options, config=config)
        daemons.append(daemon)
        if kind == "patrol":
            wait_for(lambda: ended_runs(folder), MISSION_TIMEOUT_S + 120, "the scheduled patrol")
            claims_of_patrol(result, folder, log)
        else:
            second = subprocess.run(program("go", GOAL, "--json"), capture_output=True, text=True,
                                    env=env, timeout=MISSION_TIMEOUT_S)  # fmt: skip
            report = json.loads(second.stdout.strip().splitlines()[-1]) if second.stdout else {}
            result.told = report.get("detail") or second.stderr.strip()[-200:]
            # A go refused before it started has no outcome: why it was refused instead.
            result.outcomes.append(str(report.get("outcome") or report.get("why")))
            time.sleep(1.0)
            if report.get("outcome") == "arrived":
                goal = load_floorplan(PLAN).rooms[GOAL].at
                result.claims.append({"goal": GOAL, "error_m": math.dist(at(truth(log),
                                      time.monotonic()), goal)})  # fmt: skip
        rows = truth(log)
        found_at = daemon.first_fix
        result.found_after_s = None if found_at is None else round(found_at - restarted, 2)
        result.unverified_travel_m = travel(rows, restarted, found_at or math.inf)
    except (TimeoutError, subprocess.TimeoutExpired, OSError, ValueError) as error:
        result.problem = str(error)
    finally:
        for daemon in daemons:
            daemon.stop()
        sim.send_signal(signal.SIGTERM)
        try:
            sim.wait(timeout=10)
        except subprocess.TimeoutExpired:
            sim.kill()
    return result


def schedule(folder: Path) -> Path:
    """A settings file with the patrol due at the next whole minute but one, and the
    patrol in the routes folder."""
    routes = folder / "routes"
    routes.mkdir(exist_ok=True)
    stops = "\n".join(f"  - room: {room}" for room in PATROL)
    (routes / "night.patrol.yaml").write_text(f"rounds: 1\nsnapshots: false\nstops:\n{stops}\n")
    due = (dt.datetime.now() + dt.timedelta(minutes=2)).replace(second=0, microsecond=0)
    until = due + dt.timedelta(minutes=30)
    path = folder / "config.toml"
    path.write_text(f'routes = "{routes}"\n\n[[schedule]]\npatrol = "night"\nevery = "30m"\n'
                    f'from = "{due:%H:%M}"\nto = "{until:%H:%M}"\n')  # fmt: skip
    return path


def ended_runs(folder: Path) -> list[dict]:
    runs = folder / "data" / "giraff-console" / "patrol-runs"
    ended = []
    for path in sorted(runs.glob("*.jsonl")) if runs.exists() else []:
        lines = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
        if lines and lines[-1].get("event") == "end":
            ended.append({"path": str(path), "lines": lines})
    return ended


def claims_of_patrol(result: Result, folder: Path, log: Path) -> None:
    """Each stop of the patrol: its outcome, and for a claimed arrival its true error
    at the time the log wrote the stop (local wall time, turned to the monotonic clock
    the true pose is logged on)."""
    offset = time.time() - time.monotonic()
    plan = load_floorplan(PLAN)
    rows = truth(log)
    for run in ended_runs(folder):
        for line in run["lines"]:
            if line.get("event") == "end":
                result.told = f"patrol ended: {line.get('why')}"
            if line.get("event") != "stop":
                continue
            result.outcomes.append(line.get("outcome", "?"))
            if line.get("outcome") != "arrived":
                continue
            moment = dt.datetime.fromisoformat(line["at"]).timestamp() - offset
            room = plan.start if line["place"] == "dock" else line["place"]
            goal = plan.rooms[room].at
            result.claims.append({"goal": line["place"],
                                  "error_m": math.dist(at(rows, moment), goal)})  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", default="go,patrol,no-camera")
    parser.add_argument("--seeds", default="1,2")
    parser.add_argument("--save", type=Path)
    args = parser.parse_args()
    results = []
    for kind in args.kinds.split(","):
        for seed in (int(s) for s in args.seeds.split(",")):
            folder = Path(tempfile.mkdtemp(prefix=f"restart-{kind}-{seed}-"))
            try:
                result = scenario(kind, seed, folder)
            finally:
                shutil.rmtree(folder, ignore_errors=True)
            results.append(result)
            worst = max((claim["error_m"] for claim in result.claims), default=math.nan)
            print(
                f"{kind:<9} seed {seed}: run-on {result.run_on_m:.3f} m; unverified travel "
                f"{result.unverified_travel_m:.3f} m (fix after {result.found_after_s} s); "
                f"outcomes {result.outcomes}; claims {len(result.claims)}, worst "
                f"{worst:.3f} m; told: {result.told[:120]}"
                f"{'; PROBLEM ' + result.problem if result.problem else ''}",
                flush=True,
            )
            print(f"    the killed daemon's client said: {result.killed_client_said}")
    false = [claim for result in results for claim in result.claims if claim["error_m"] > WITHIN_M]
    print(f"false arrivals: {len(false)}; largest unverified travel "
          f"{max(result.unverified_travel_m for result in results):.3f} m; largest run-on "
          f"{max(result.run_on_m for result in results):.3f} m")  # fmt: skip
    if args.save is not None:
        args.save.write_text(json.dumps([asdict(result) for result in results], indent=1))


if __name__ == "__main__":
    main()
