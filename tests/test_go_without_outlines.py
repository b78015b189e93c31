"""`go` on a plan without room outlines (issue 16): room points and doors over a scanned
grid, or no grid at all. The simulated building takes its walls from the grid; before,
the synthetic camera's world refused to be built ("a world needs walls")."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from giraff_console.cli.main import main
from giraff_console.clock import VirtualClock
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.odometry import Pose
from giraff_console.runtime.sim_site import SimulatedSite
from giraff_console.sim.board import GiraffBoard
from tests.planning.scanned_building import PLAN, write_scanned_plan

# The same rooms and doors with no grid: rooms joined by straight lines on open floor.
NO_GRID = PLAN[: PLAN.index("grid:")] + "start: corridor\n"


def go(capsys, room: str, floorplan: Path) -> tuple[int, dict | None, str]:
    code = main(["go", room, "--sim", "--floorplan", str(floorplan), "--sim-speed", "inf",
                 "--json"])  # fmt: skip
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


def test_the_simulated_building_has_the_scans_walls(tmp_path):
    plan = load_floorplan(write_scanned_plan(tmp_path))
    board = GiraffBoard(VirtualClock())
    site = SimulatedSite(board, plan, Pose(6.0, 1.0, math.pi / 2))
    assert len(site.world.walls) > 20
    # Solid where the scan is: the corridor's north wall, but not its doorways.
    solids = board.solids
    assert solids is not None
    assert solids.touches(3.0, 1.75) and not solids.touches(2.0, 1.75)
    # The camera sees them: the corridor's far wall, through the doorway, is drawn.
    _, world_camera = site.camera(VirtualClock())
    image = world_camera.render(board.true_pose, 400, 300)
    open_floor = SimulatedSite(GiraffBoard(VirtualClock()), load_floorplan(
        write_scanned_plan(tmp_path, NO_GRID, "open")), None).world  # fmt: skip
    assert len(open_floor.walls) == 0
    assert image.std() > 20


@pytest.mark.parametrize("room", ["east-room", "west-room"])
def test_go_arrives_on_a_scanned_plan_without_outlines(tmp_path, capsys, room):
    # No markers on this plan: the odometry's arrival, said to be unconfirmed (exit 3).
    code, report, err = go(capsys, room, write_scanned_plan(tmp_path))
    assert code == 3, err
    assert report is not None and report["outcome"] == "arrived_unverified"
    assert report["why"] == "done" and report["error_m"] <= 0.03
    assert "Traceback" not in err


def test_go_arrives_on_a_plan_of_points_and_doors_alone(tmp_path, capsys):
    code, report, err = go(capsys, "east-room", write_scanned_plan(tmp_path, NO_GRID))
    assert code == 3, err
    assert report is not None and report["outcome"] == "arrived_unverified"
    assert report["error_m"] <= 0.03
    assert "Traceback" not in err


def test_a_shut_door_on_a_scanned_plan_is_shut_in_the_simulated_building(tmp_path):
    text = PLAN.replace("at: [2, 2.05], width: 1.0}", "at: [2, 2.05], width: 1.0, open: false}")
    plan = load_floorplan(write_scanned_plan(tmp_path, text))
    board = GiraffBoard(VirtualClock())
    SimulatedSite(board, plan, None)
    assert board.solids is not None and board.solids.touches(2.0, 1.75)


def test_go_from_the_shell_arrives_with_no_traceback(tmp_path):
    # As a user runs it: the installed command, from another folder.
    path = write_scanned_plan(tmp_path)
    command = [sys.executable, "-m", "giraff_console", "go", "middle-room", "--sim",
               "--floorplan", str(path), "--sim-speed", "inf", "--json"]  # fmt: skip
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env=os.environ | {"CI": "true"}, stdin=subprocess.DEVNULL)  # fmt: skip
    assert done.returncode == 3, done.stderr
    assert "Traceback" not in done.stderr
    report = json.loads(done.stdout)
    assert report["outcome"] == "arrived_unverified" and report["error_m"] <= 0.03
    assert np.hypot(*(np.array(report["pose_true"][:2]) - (6.0, 5.0))) <= 0.03
