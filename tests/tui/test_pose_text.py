"""The pose on the top line with how well it is known: `X=12.40±0.03 Y=3.10±0.03 H=90.0±1.2`."""

from __future__ import annotations

import math

from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose
from giraff_console.tui.top_bar import pose_text

POSE = Pose(12.4, 3.1, math.pi / 2)


def estimate(sigma_x: float, sigma_y: float, sigma_heading_deg: float, **kwargs) -> Estimate:
    """An estimate at POSE whose x and y are known to `sigma_x` and `sigma_y` metres."""
    heading = math.radians(sigma_heading_deg)
    covariance = ((sigma_x**2, 0.0, 0.0), (0.0, sigma_y**2, 0.0), (0.0, 0.0, heading**2))
    worst = max(sigma_x, sigma_y)
    return Estimate(POSE, POSE, covariance, worst, heading, (worst, min(sigma_x, sigma_y), 0.0),
                    **kwargs)  # fmt: skip


def test_a_found_pose_shows_one_sigma_of_x_y_and_the_heading_in_degrees():
    text, style = pose_text(POSE, estimate(0.03, 0.02, 1.2, landmarks=True, found=True))
    assert text == "X=12.40±0.03 Y=3.10±0.02 H=90.0±1.2"
    assert style == "bold"


def test_x_and_y_each_show_their_own_spread_from_the_covariance_diagonal():
    # Known to 5 cm across x but only 40 cm along y: the worst direction is not both.
    text, _ = pose_text(POSE, estimate(0.05, 0.4, 2.0))
    assert "X=12.40±0.05 " in text and "Y=3.10±0.40 " in text


def test_without_an_estimate_as_in_a_playback_the_pose_has_no_spread():
    assert pose_text(POSE, None) == ("X=12.40 Y=3.10 H=90.0", "bold")


def test_without_markers_in_the_plan_the_dead_reckonings_spread_shows_unmarked():
    text, style = pose_text(POSE, estimate(0.6, 0.6, 9.0))
    assert text == "X=12.40±0.60 Y=3.10±0.60 H=90.0±9.0"
    assert style == "bold"  # dead reckoning is all there is: nothing to find it by


def test_an_endless_spread_is_left_out():
    text, _ = pose_text(POSE, estimate(math.inf, math.inf, math.inf))
    assert text == "X=12.40 Y=3.10 H=90.0"
    covariance = ((math.nan, 0.0, 0.0), (0.0, -1e-9, 0.0), (0.0, 0.0, 1e-4))
    broken = Estimate(POSE, POSE, covariance, 0.03, 0.01, (0.03, 0.03, 0.0))
    assert pose_text(POSE, broken)[0] == "X=12.40 Y=3.10 H=90.0±0.6"


def test_a_pose_no_marker_has_found_yet_says_so_in_orange():
    text, style = pose_text(POSE, estimate(0.05, 0.05, 3.0, landmarks=True, found=False))
    assert text == "X=12.40±0.05 Y=3.10±0.05 H=90.0±3.0 (not found)"
    assert "on dark_orange" in style


def test_a_lost_pose_says_so_in_orange_and_a_loose_one_is_yellow():
    lost, style = pose_text(POSE, estimate(0.3, 0.1, 2.0, landmarks=True, found=True))
    assert lost.endswith("(lost)") and "on dark_orange" in style
    loose, style = pose_text(POSE, estimate(0.15, 0.1, 2.0, landmarks=True, found=True))
    assert "(" not in loose and style == "bold yellow"


def test_a_heading_a_hair_short_of_east_reads_zero_not_360():
    assert pose_text(Pose(1.0, 2.0, -1e-4), None)[0] == "X=1.00 Y=2.00 H=0.0"
