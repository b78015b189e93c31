"""The localisation: the odometry followed, sightings moved to the present, the first
marker placing a robot that is not where the console assumed, and the gate holding
once it is found."""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.clock import VirtualClock
from giraff_console.link.motor_state import MotorState
from giraff_console.robot.ekf import Observation, PoseFilter
from giraff_console.robot.localisation import (
    LOOK_SIGMA_M,
    SCAN_FLOOR_M,
    Localisation,
    PoseBasis,
    PoseFix,
)
from giraff_console.robot.odometry import Odometry, Pose
from giraff_console.robot.wheel_odometers import Reading

BASE = 0.499
# A marker on a wall 3 m ahead of the dock, facing back along -x.
WALL_MARKER = Pose(5.0, 0.0, math.pi)
MARKERS = {7: WALL_MARKER, 8: Pose(5.0, 1.5, math.pi)}


class Wheels:
    """Totals of the thesis's board, fed to the odometry as polls would."""

    def __init__(self, odometry: Odometry, clock: VirtualClock) -> None:
        self.odometry, self.clock = odometry, clock
        self.left = self.right = 0.0
        self.feed()

    def feed(self) -> None:
        state = MotorState(0.0, 0.0, 0.0, 0.0, 0.0, None, self.left, self.right, 0,
                           self.clock.now())  # fmt: skip
        self.odometry.update(state)

    def drive(self, left: float, right: float, steps: int, localisation: Localisation) -> None:
        for _ in range(steps):
            self.left += left / steps
            self.right += right / steps
            self.clock.advance(0.05)
            self.feed()
            localisation.follow()


def sighting(true_pose: Pose, marker: Pose, marker_id: int, time: float) -> Observation:
    """What a perfect camera at `true_pose` sees of `marker`."""
    seen = PoseFilter(true_pose).expected(marker)
    return Observation(marker_id, seen.distance_m, seen.bearing_rad, seen.facing_rad, time)


def make(markers=MARKERS) -> tuple[Localisation, Wheels, VirtualClock]:
    clock = VirtualClock(100.0)
    odometry = Odometry(Pose(2.0, 0.0, 0.0), wheel_base=BASE, reading=Reading.TOTALS)
    localisation = Localisation(odometry, markers, now=clock.now)
    localisation.place(Pose(2.0, 0.0, 0.0))
    return localisation, Wheels(odometry, clock), clock


def test_without_markers_the_estimate_is_the_odometry():
    localisation, wheels, _ = make(markers={})
    quarter_turn = math.pi / 2 * BASE / 4
    # A turn on the spot too: with nothing to check it by, no caster turn is expected.
    wheels.drive(-quarter_turn, quarter_turn, 10, localisation)
    wheels.drive(1.0, 1.3, 20, localisation)
    estimate = localisation.estimate()
    assert estimate.pose.x == pytest.approx(estimate.odometry.x, abs=1e-9)
    assert estimate.pose.y == pytest.approx(estimate.odometry.y, abs=1e-9)
    assert estimate.pose.heading == pytest.approx(estimate.odometry.heading, abs=1e-9)
    assert not estimate.landmarks and not estimate.lost and not estimate.unsure
    # Driving grew the uncertainty from the dock's few centimetres.
    assert estimate.sigma_m > 0.05
    assert estimate.caster_rate == 0.0


def test_with_markers_a_turn_on_the_spot_expects_the_casters_to_turn_on_the_same_way():
    localisation, wheels, clock = make()
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    quarter_turn = math.pi / 2 * BASE / 2
    wheels.drive(quarter_turn, -quarter_turn, 10, localisation)  # clockwise
    estimate = localisation.estimate()
    assert estimate.caster_rate < 0  # clockwise too: steer left against it
    wheels.drive(1.5, 1.5, 30, localisation)
    estimate = localisation.estimate()
    # The estimate has turned on clockwise past the odometry as the casters settled.
    assert estimate.pose.heading < estimate.odometry.heading - math.radians(15)


def test_a_sighting_that_agrees_confirms_the_pose_and_shrinks_it():
    localisation, wheels, clock = make()
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)  # the operator says so
    wheels.drive(1.0, 1.0, 20, localisation)  # to x = 3, as given
    before = localisation.estimate().sigma_m
    localisation.sighted([sighting(Pose(3.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.found and estimate.seen == (7,)
    assert estimate.sigma_m < before
    assert math.hypot(estimate.pose.x - 3.0, estimate.pose.y) < 0.01


def test_a_pose_only_assumed_is_no_evidence_the_first_marker_is_weighed_against():
    # Assumed 4 cm and 2 degrees off the truth, within the start's gate: fused, the
    # assumption would pull the fix its way; the marker places the robot on its own.
    localisation, _wheels, clock = make()
    true = Pose(2.04, 0.0, math.radians(2.0))
    localisation.sighted([sighting(true, WALL_MARKER, 7, clock.now())])
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.found and estimate.basis is PoseBasis.MARKER
    assert math.hypot(estimate.pose.x - true.x, estimate.pose.y - true.y) < 0.005
    assert math.degrees(abs(estimate.pose.heading - true.heading)) < 0.3


def test_the_first_marker_places_a_robot_that_was_not_on_its_dock():
    localisation, _wheels, clock = make()
    assert localisation.estimate().lost  # nothing has confirmed the assumed dock
    # Really 1.2 m to the left and turned 20 degrees: far outside the start's gate.
    true = Pose(2.0, 1.2, math.radians(20))
    localisation.sighted([sighting(true, WALL_MARKER, 7, clock.now())])
    localisation.correct()
    estimate = localisation.estimate()
    # One sighting 3 m off places it to decimetres across the line of sight (the
    # facing's 6 degrees), which later sightings narrow.
    assert estimate.found and estimate.sigma_m < 0.5
    assert math.hypot(estimate.pose.x - true.x, estimate.pose.y - true.y) < 0.01
    assert math.degrees(abs(estimate.pose.heading - true.heading)) < 0.5


def test_once_found_a_marker_moved_a_metre_is_rejected_by_the_gate():
    localisation, _wheels, clock = make()
    true = Pose(2.0, 0.0, 0.0)
    localisation.sighted([sighting(true, WALL_MARKER, 7, clock.now())])
    localisation.correct()
    found = localisation.estimate().pose
    # Marker 8 hangs a metre along the wall from where the plan says.
    moved = Pose(5.0, 0.5, math.pi)
    localisation.sighted([sighting(true, moved, 8, clock.now())])
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.rejected == (8,) and estimate.seen == (7,)
    assert estimate.pose == found
    assert localisation.rejections == {8: 1} and localisation.used == {7: 1}


def test_a_sighting_is_moved_to_the_present_by_the_odometry_since_its_frame():
    localisation, wheels, clock = make()
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    taken_at = clock.now()
    true_then = Pose(2.0, 0.0, 0.0)
    # The robot drives on for 0.4 s (0.2 m, turning) before the frame's markers arrive.
    wheels.drive(0.18, 0.22, 8, localisation)
    localisation.sighted([sighting(true_then, WALL_MARKER, 7, taken_at)])
    before = localisation.estimate().pose
    localisation.correct()
    after = localisation.estimate().pose
    # Taken as it is, the old frame would pull the estimate back towards x = 2; moved to
    # the present it agrees with where the odometry has the robot now.
    assert math.hypot(after.x - before.x, after.y - before.y) < 0.005
    assert localisation.estimate().seen == (7,)


def test_a_frame_older_than_the_history_is_dropped():
    localisation, wheels, clock = make()
    old = clock.now()
    wheels.drive(0.5, 0.5, 40, localisation)  # 2 s
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, old)])
    localisation.correct()
    assert localisation.estimate().seen == ()


def test_a_marker_the_plan_does_not_have_is_reported_once_and_ignored():
    said: list[str] = []
    clock = VirtualClock()
    odometry = Odometry(Pose(), wheel_base=BASE)
    localisation = Localisation(odometry, MARKERS, now=clock.now, report=said.append)
    Wheels(odometry, clock)
    localisation.follow()
    for _ in range(3):
        localisation.sighted([Observation(99, 2.0, 0.0, math.pi, clock.now())])
        localisation.correct()
    assert len(said) == 1 and "99" in said[0]
    assert not localisation.estimate().found


def test_the_odometrys_jump_moves_the_estimate_with_it():
    localisation, wheels, _ = make(markers={})
    wheels.drive(1.0, 1.0, 10, localisation)
    odometry = localisation.odometry
    # The first-motion check replaced the reading: the odometry's pose jumps 0.3 m.
    odometry.pose = Pose(odometry.pose.x + 0.3, odometry.pose.y, odometry.pose.heading)
    localisation.follow()
    assert localisation.pose.x == pytest.approx(odometry.pose.x, abs=1e-9)


def test_dead_reckoning_after_a_turn_in_place_and_a_long_drive_is_lost():
    localisation, wheels, clock = make()
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    half_turn = math.pi / 2 * BASE / 2
    wheels.drive(-half_turn, half_turn, 10, localisation)  # a quarter turn on the spot
    wheels.drive(4.0, 4.0, 80, localisation)
    estimate = localisation.estimate()
    assert estimate.sigma_m > LOOK_SIGMA_M and estimate.lost


def test_a_marker_too_far_to_place_the_robot_by_waits_for_a_nearer_one():
    localisation, _wheels, clock = make(markers={7: WALL_MARKER, 9: Pose(7.0, 0.0, math.pi)})
    true = Pose(2.0, 0.8, 0.0)
    localisation.sighted([sighting(true, Pose(7.0, 0.0, math.pi), 9, clock.now())])  # 5 m
    localisation.correct()
    assert not localisation.estimate().found
    localisation.sighted([sighting(true, WALL_MARKER, 7, clock.now())])  # 3 m
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.found and abs(estimate.pose.y - 0.8) < 0.01


def test_a_frame_between_two_polls_is_moved_from_where_the_robot_was_between_them():
    localisation, wheels, clock = make()
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    wheels.drive(0.1, 0.1, 1, localisation)  # one poll, 0.05 s later, 0.1 m on
    # A frame taken half-way between the polls, 0.05 m on, reaching the loop a poll later.
    halfway = clock.now() - 0.025
    wheels.drive(0.1, 0.1, 1, localisation)
    localisation.sighted([sighting(Pose(2.05, 0.0, 0.0), WALL_MARKER, 7, halfway)])
    before = localisation.estimate().pose
    localisation.correct()
    after = localisation.estimate().pose
    assert localisation.estimate().seen == (7,)
    assert abs(after.x - before.x) < 0.002


def test_a_robot_whose_casters_do_not_turn_it_is_not_steered_against_them():
    # The ideal simulator's robot: its casters never turn it (none of §3.2.1.5's drift).
    localisation, wheels, clock = make()
    localisation.casters_turn_up_to(0.0)
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    quarter_turn = math.pi / 2 * BASE / 2
    wheels.drive(quarter_turn, -quarter_turn, 10, localisation)
    estimate = localisation.estimate()
    assert estimate.caster_rate == 0.0 and estimate.caster_pending == 0.0
    wheels.drive(1.5, 1.5, 30, localisation)
    estimate = localisation.estimate()
    assert estimate.pose.heading == pytest.approx(estimate.odometry.heading, abs=1e-6)


# A scan's fix as planning/scan_matching.py's matcher gives one: 3 cm and a degree.
FIX_COVARIANCE = np.diag([0.03**2, 0.03**2, math.radians(1.0) ** 2])


def test_a_scan_fix_corrects_a_pose_given_and_is_a_fresh_fix():
    localisation, wheels, clock = make(markers={})
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)
    wheels.drive(1.0, 1.0, 20, localisation)  # 1 m on: the odometry says (3, 0)
    assert localisation.estimate().since_fix_m == pytest.approx(1.0)
    # The scan, taken now, fits the map 6 cm to the left and a degree turned.
    fitted = Pose(3.0, 0.06, math.radians(1.0))
    localisation.scan_fitted(PoseFix(clock.now(), fitted, FIX_COVARIANCE))
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.basis is PoseBasis.SCAN and estimate.found
    assert estimate.since_fix_m == 0.0
    # Weighed against the odometry's metre: most of the way to the fix.
    assert 0.03 < estimate.pose.y < 0.06
    assert localisation.scan_fixes == {True: 1}


def test_a_scan_fix_is_moved_to_the_present_by_the_odometry_since_its_revolution():
    localisation, wheels, clock = make(markers={})
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)
    taken_at = clock.now()
    # The robot drives on 0.3 m before the revolution's match is ready.
    wheels.drive(0.3, 0.3, 6, localisation)
    localisation.scan_fitted(PoseFix(taken_at, Pose(2.0, 0.05, 0.0), FIX_COVARIANCE))
    localisation.correct()
    pose = localisation.estimate().pose
    # Taken as it is, the fix would pull the estimate back towards x = 2.
    assert pose.x == pytest.approx(2.3, abs=0.005)
    assert pose.y > 0.02


def test_a_scan_fix_never_places_a_pose_only_assumed():
    # A restarted daemon's kept pose: the matcher looked only round it, and a building
    # has many places alike, so a fit there says nothing of where the robot is.
    localisation, _wheels, clock = make(markers={})
    localisation.scan_fitted(PoseFix(clock.now(), Pose(2.1, 0.0, 0.0), FIX_COVARIANCE))
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.basis is PoseBasis.ASSUMED and not estimate.found
    assert estimate.pose == Pose(2.0, 0.0, 0.0)
    assert not localisation.scan_fixes


def test_a_scan_fix_far_from_a_well_known_pose_is_rejected_by_the_gate():
    localisation, _wheels, clock = make()
    localisation.sighted([sighting(Pose(2.0, 0.0, 0.0), WALL_MARKER, 7, clock.now())])
    localisation.correct()
    found = localisation.estimate().pose
    localisation.scan_fitted(PoseFix(clock.now(), Pose(2.5, 0.0, 0.0), FIX_COVARIANCE))
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.pose == found and estimate.basis is PoseBasis.MARKER
    assert localisation.scan_fixes == {False: 1}


def test_a_scan_fix_does_not_stand_for_a_marker_that_would_place_the_robot():
    # Placed by hand 0.6 m short of where it stands; the scan, matched round the wrong
    # place, agrees with it. The first marker still places the robot where it is.
    localisation, _wheels, clock = make()
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)
    localisation.scan_fitted(PoseFix(clock.now(), Pose(2.0, 0.0, 0.0), FIX_COVARIANCE))
    localisation.correct()
    assert localisation.estimate().basis is PoseBasis.SCAN
    assert not localisation.estimate().found
    true = Pose(2.6, 0.0, 0.0)
    localisation.sighted([sighting(true, WALL_MARKER, 7, clock.now())])
    localisation.correct()
    estimate = localisation.estimate()
    assert estimate.found and estimate.basis is PoseBasis.MARKER
    assert abs(estimate.pose.x - 2.6) < 0.01


def test_a_corridors_scan_fix_refreshes_nothing_it_did_not_measure():
    localisation, wheels, clock = make(markers={})
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)
    wheels.drive(1.0, 1.0, 20, localisation)
    localisation.touched()
    along_x = FIX_COVARIANCE.copy()
    along_x[0, 0] = 1.0  # a corridor along x: known across it only
    localisation.scan_fitted(PoseFix(clock.now(), Pose(3.0, 0.02, 0.0), along_x, pinned=False))
    localisation.correct()
    estimate = localisation.estimate()
    assert localisation.scan_fixes == {True: 1}
    assert estimate.since_fix_m == pytest.approx(1.0) and estimate.contact


def fixed_every_tenth_for_3_m() -> tuple[Localisation, Wheels, VirtualClock]:
    """Driven 3 m along x from a pose given, the same walls fitted every 0.1 m."""
    localisation, wheels, clock = make(markers={})
    localisation.place(Pose(2.0, 0.0, 0.0), basis=PoseBasis.GIVEN)
    for step in range(30):
        wheels.drive(0.1, 0.1, 2, localisation)
        fitted = Pose(2.1 + 0.1 * step, 0.0, 0.0)
        localisation.scan_fitted(PoseFix(clock.now(), fitted, FIX_COVARIANCE))
        localisation.correct()
    return localisation, wheels, clock


def test_scan_fixes_do_not_make_the_filter_surer_than_the_map():
    # The same walls every 0.1 m for 3 m: fused each time, the filter would believe
    # itself to a centimetre (the review measured 0.016 m).
    localisation, _wheels, _clock = fixed_every_tenth_for_3_m()
    estimate = localisation.estimate()
    # The last fix fused from just above the floor takes it a little below.
    assert estimate.sigma_m >= 0.8 * SCAN_FLOOR_M
    assert estimate.since_fix_m == 0.0  # each still confirmed the pose
    assert localisation.scan_fixes == {True: 30}


def unsure_heading_below_the_floor():
    """A localisation whose position is known better than the map (scan fixes every
    0.1 m for 3 m), just after the casters began to let go of a quarter turn on the
    spot: its heading is unsure by several degrees."""
    localisation, wheels, clock = fixed_every_tenth_for_3_m()
    quarter_turn = math.pi / 2 * BASE / 2
    wheels.drive(-quarter_turn, quarter_turn, 10, localisation)
    wheels.drive(0.1, 0.1, 2, localisation)
    estimate = localisation.estimate()
    assert estimate.sigma_m < SCAN_FLOOR_M
    assert localisation.filter.sigma_heading > math.radians(4.0)
    return localisation, clock, estimate


def test_a_scan_fix_corrects_a_heading_the_casters_made_unsure_below_the_floor():
    # A fix's heading then corrects the filter's; its position, no better than the
    # map, is not fused. Only confirming the pose here, the robot drove its run in to a
    # door 14 degrees off its line and clipped the frame (tests/lidar's doorway drawn
    # off, on a busy machine).
    def fixed(aside: float):
        localisation, clock, before = unsure_heading_below_the_floor()
        p = before.pose
        turned = Pose(p.x + aside, p.y, p.heading + math.radians(8.0))
        localisation.scan_fitted(PoseFix(clock.now(), turned, FIX_COVARIANCE))
        localisation.correct()
        assert localisation.scan_fixes == {True: 31}
        return before, localisation.estimate(), localisation.filter.sigma_heading

    before, after, sigma_heading = fixed(0.0)
    assert math.degrees(after.pose.heading - before.pose.heading) > 7.0
    assert sigma_heading < math.radians(1.5)
    # The position moved only as far as it is tied to the heading, and is no surer; a
    # fix 3 cm to the side, which it says no better than the map, moves it no more.
    moved = math.hypot(after.pose.x - before.pose.x, after.pose.y - before.pose.y)
    assert moved < 0.01
    assert after.sigma_m >= 0.95 * before.sigma_m
    _, aside, _ = fixed(0.03)
    assert aside.pose == after.pose


def test_a_heading_fix_from_a_search_cut_short_only_confirms_below_the_floor():
    localisation, clock, before = unsure_heading_below_the_floor()
    p = before.pose
    turned = Pose(p.x, p.y, p.heading + math.radians(8.0))
    localisation.scan_fitted(PoseFix(clock.now(), turned, FIX_COVARIANCE, pinned=False))
    localisation.correct()
    assert localisation.scan_fixes == {True: 31}
    assert localisation.estimate().pose == p


def test_a_heading_fix_whose_position_is_far_off_is_rejected_whole():
    localisation, clock, before = unsure_heading_below_the_floor()
    p = before.pose
    elsewhere = Pose(p.x + 0.5, p.y, p.heading + math.radians(8.0))
    localisation.scan_fitted(PoseFix(clock.now(), elsewhere, FIX_COVARIANCE))
    localisation.correct()
    assert localisation.scan_fixes == {True: 30, False: 1}
    assert localisation.estimate().pose == p
