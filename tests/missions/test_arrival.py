"""Arriving (missions/arrival.py): what a path mission at the end of its plan says of it."""

from __future__ import annotations

import math

import pytest

from giraff_console.missions.arrival import Arrival, Verdict
from giraff_console.missions.certainty import ARRIVAL_TRIES
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.odometry import Pose

GOAL = (0.0, 0.0)


def estimate(pose: Pose, sigma_m: float, sigma_deg: float = 0.5) -> Estimate:
    sigma_heading = math.radians(sigma_deg)
    covariance = ((sigma_m**2, 0.0, 0.0), (0.0, sigma_m**2, 0.0), (0.0, 0.0, sigma_heading**2))
    return Estimate(pose, pose, covariance, sigma_m, sigma_heading, (sigma_m, sigma_m, 0.0),
                    landmarks=True, found=True, basis=PoseBasis.MARKER)  # fmt: skip


def out_of_tries() -> Arrival:
    arrival = Arrival()
    arrival.tries = ARRIVAL_TRIES
    arrival.came_in_again = True
    return arrival


@pytest.mark.parametrize(("off", "sigma_m", "sigma_deg", "askew_deg", "verdict"), [
    (0.03, 0.01, 0.5, 0.0, Verdict.ARRIVED),  # well within, with two sigma to spare
    (0.07, 0.01, 0.5, 0.0, Verdict.ARRIVED),  # 0.07 + 0.02: still within 0.10 m
    (0.08, 0.02, 0.5, 0.0, Verdict.UNCONFIRMED),  # 0.08 + 0.04: may be past 0.10 m
    (0.03, 0.01, 0.5, 1.5, Verdict.ARRIVED),  # 1.5 + 1 degrees: within 3
    (0.03, 0.01, 1.0, 1.5, Verdict.UNCONFIRMED),  # 1.5 + 2 degrees: may be past 3
    (0.12, 0.01, 0.5, 0.0, Verdict.GIVE_UP),  # too far off by the estimate itself
])  # fmt: skip
def test_a_robot_out_of_tries_claims_only_what_two_sigma_leave_within_the_bounds(
    off, sigma_m, sigma_deg, askew_deg, verdict
):
    heading = math.radians(askew_deg)
    judged = out_of_tries().judge(Pose(off, 0.0, heading), estimate(Pose(off, 0.0, heading),
                                  sigma_m, sigma_deg), GOAL, 0.0)  # fmt: skip
    assert judged.verdict is verdict
