"""The markers the robot finds itself by, and how well each is known (issue 25, §2.3.4):
learnt from where the robot is known to be, and a known one that moved noticed."""

from __future__ import annotations

import math

import numpy as np

from giraff_console.robot.ekf import Observation, PoseFilter
from giraff_console.robot.marker_map import (
    MOVED_AFTER,
    MarkerBelief,
    MarkerMap,
    MarkerState,
    hand_covariance,
)
from giraff_console.robot.odometry import Pose

MARKER = Pose(3.0, 0.0, math.pi)  # on a wall 3 m ahead, facing back along -x
ROBOT_COVARIANCE = np.diag([0.02**2, 0.02**2, math.radians(1.0) ** 2])


def seen_from(robot: Pose, marker: Pose = MARKER, marker_id: int = 7) -> Observation:
    expected = PoseFilter().expected(marker, robot)
    return Observation(marker_id, expected.distance_m, expected.bearing_rad, expected.facing_rad)


def test_a_new_marker_is_learnt_from_where_the_robot_is_known_to_be_and_then_used():
    markers = MarkerMap(learn_new=True)
    notes = [markers.learn(7, Pose(0.0, y, 0.0), ROBOT_COVARIANCE, seen_from(Pose(0.0, y, 0.0)))
             for y in (-0.5, 0.0, 0.5)]  # fmt: skip
    belief = markers.beliefs[7]
    assert belief.state is MarkerState.KNOWN and notes[-1] is not None and "learnt" in notes[-1]
    assert math.dist((belief.pose.x, belief.pose.y), (MARKER.x, MARKER.y)) < 0.01
    # Never known better than the robot that saw it.
    assert belief.sigma_m >= 0.02 - 1e-9
    assert markers.known() == {7: belief.pose}


def test_nothing_is_learnt_from_a_robot_that_does_not_know_where_it_is():
    markers = MarkerMap(learn_new=True)
    lost = np.diag([0.3**2, 0.3**2, 0.3**2])
    assert markers.learn(7, Pose(), lost, seen_from(Pose())) is None
    assert 7 not in markers


def test_outside_a_survey_a_marker_not_on_the_map_is_not_added():
    markers = MarkerMap()
    markers.learn(7, Pose(), ROBOT_COVARIANCE, seen_from(Pose()))
    assert 7 not in markers


def test_a_known_marker_rejected_again_and_again_while_others_vouch_has_moved():
    markers = MarkerMap({7: MarkerBelief(MARKER, hand_covariance())})
    for _ in range(MOVED_AFTER - 1):
        assert markers.rejected(7, confirmed_by_others=True) is None
    markers.accepted(7)  # one good sighting between: it starts over
    notes = [markers.rejected(7, confirmed_by_others=True) for _ in range(MOVED_AFTER)]
    assert notes[-1] is not None and "not where the plan says" in notes[-1]
    assert markers.beliefs[7].state is MarkerState.MOVED and 7 not in markers.known()
    # Learnt again where it hangs now.
    moved = Pose(3.0, 1.0, math.pi)
    for y in (-0.5, 0.0, 0.5, 0.2):
        markers.learn(7, Pose(0.0, y, 0.0), ROBOT_COVARIANCE, seen_from(Pose(0.0, y, 0.0), moved))
    again = markers.beliefs[7]
    assert again.state is MarkerState.KNOWN and abs(again.pose.y - 1.0) < 0.02


def test_rejections_while_nothing_else_vouches_for_the_robot_prove_nothing():
    markers = MarkerMap({7: MarkerBelief(MARKER, hand_covariance())})
    for _ in range(3 * MOVED_AFTER):
        assert markers.rejected(7, confirmed_by_others=False) is None
    assert markers.beliefs[7].state is MarkerState.KNOWN
