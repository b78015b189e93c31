"""The pose kept on disk for a console or daemon that starts again (issue 25, item 0)."""

from __future__ import annotations

import json
import math
import os
import stat
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_keeper import (
    MISSED_M,
    PoseKeeper,
    PoseKeeperError,
    read_kept,
)
from giraff_console.robot.telemetry import LinkState, Telemetry

PLAN = Path("/somewhere/care-home.yaml")


def estimate(x: float, basis: PoseBasis = PoseBasis.MARKER) -> Estimate:
    covariance = ((0.0004, 0.0, 0.0), (0.0, 0.0004, 0.0), (0.0, 0.0, 0.0003))
    return Estimate(Pose(x, 2.0, 0.5), Pose(x, 2.0, 0.5), covariance, 0.02, 0.017,
                    (0.02, 0.02, 0.0), basis=basis)  # fmt: skip


def snapshot(seen: Estimate) -> Telemetry:
    return Telemetry(LinkState.CONNECTED, None, seen.pose, None, 0.0, None, True, 20.0, 0.0,
                     estimate=seen)  # fmt: skip


def kept_after(keeper: PoseKeeper, path: Path, timeout: float = 5.0) -> dict:
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert time.monotonic() < deadline, "nothing kept"
        time.sleep(0.01)
    return json.loads(path.read_text())


def test_the_estimate_is_kept_owner_only_and_read_back_as_it_was(tmp_path):
    path = tmp_path / "data" / "pose.json"
    keeper = PoseKeeper(path, PLAN)
    keeper.hear(snapshot(estimate(1.5)))
    kept_after(keeper, path)
    keeper.close()
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600
    back = read_kept(path, PLAN)
    assert back is not None and back.pose == Pose(1.5, 2.0, 0.5)
    assert back.basis is PoseBasis.MARKER
    assert np.allclose(back.covariance, np.diag([0.0004, 0.0004, 0.0003]))


def test_read_back_it_is_only_an_assumption_grown_by_what_may_have_happened_since(tmp_path):
    path = tmp_path / "pose.json"
    keeper = PoseKeeper(path, PLAN)
    keeper.hear(snapshot(estimate(1.5)))
    keeper.close()
    back = read_kept(path, PLAN)
    assert back is not None
    grown = back.as_assumed()
    assert math.sqrt(grown[0, 0]) >= MISSED_M > 0.3  # the run-on after a crash at least


def test_the_last_estimate_is_written_on_close_and_a_still_robot_writes_nothing_new(tmp_path):
    path = tmp_path / "pose.json"
    keeper = PoseKeeper(path, PLAN)
    keeper.hear(snapshot(estimate(1.0)))
    kept_after(keeper, path)
    written = path.stat().st_mtime_ns
    keeper.hear(snapshot(estimate(1.001)))  # a millimetre: not worth a write
    time.sleep(0.7)
    assert path.stat().st_mtime_ns == written
    keeper.hear(snapshot(estimate(2.0)))
    keeper.close()
    back = read_kept(path, PLAN)
    assert back is not None and back.pose.x == 2.0


def test_a_pose_kept_for_another_plan_is_not_read(tmp_path):
    path = tmp_path / "pose.json"
    keeper = PoseKeeper(path, PLAN)
    keeper.hear(snapshot(estimate(1.0)))
    keeper.close()
    assert read_kept(path, Path("/elsewhere/office.yaml")) is None
    assert read_kept(tmp_path / "none.json", PLAN) is None


@pytest.mark.parametrize(
    "text",
    ["{", "[]", '{"format": 1}', '{"format": 2, "plan": "x"}',
     json.dumps({"format": 1, "plan": str(PLAN), "pose": [0, 0, "NaN"],
                 "covariance": [[0] * 3] * 3, "basis": "marker"}),
     json.dumps({"format": 1, "plan": str(PLAN), "pose": [0, 0, 0],
                 "covariance": [[0] * 3] * 2, "basis": "marker"}),
     json.dumps({"format": 1, "plan": str(PLAN), "pose": [0, 0, 0],
                 "covariance": [[0] * 3] * 3, "basis": "psychic"}),
     "x" * 5000],
)  # fmt: skip
def test_a_broken_kept_pose_is_a_clear_error(tmp_path, text):
    path = tmp_path / "pose.json"
    path.write_text(text)
    with pytest.raises(PoseKeeperError, match=r"pose\.json"):
        read_kept(path, PLAN)


def test_a_kept_pose_that_is_a_fifo_is_refused_without_waiting(tmp_path):
    path = tmp_path / "pose.json"
    os.mkfifo(path)
    with pytest.raises(PoseKeeperError, match="not a regular file"):
        read_kept(path, PLAN)


def test_a_folder_that_cannot_be_written_is_reported_not_raised(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    keeper = PoseKeeper(blocker / "pose.json", PLAN)  # a folder under a file
    keeper.hear(snapshot(replace(estimate(1.0), basis=PoseBasis.GIVEN)))
    keeper.close()
    assert keeper.problem is not None and "cannot keep the pose" in keeper.problem
