"""The pose filter (robot/ekf.py) on synthetic data: no simulator, fixed seeds."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from statistics import NormalDist
from types import SimpleNamespace

import numpy as np
import pytest

from giraff_console.robot.ekf import (
    CHI_SQUARE,
    FilterNoise,
    Observation,
    PoseFilter,
    marker_pose,
    wrap,
)
from giraff_console.robot.odometry import Pose

WHEEL_BASE = 0.499
# A marker on a wall along y = 2, its face looking down the map (-y).
WALL_MARKER = Pose(3.0, 2.0, -math.pi / 2)


def confident(pose: Pose, sigma_m: float = 0.03, sigma_deg: float = 1.0) -> PoseFilter:
    return PoseFilter(pose, np.diag([sigma_m**2, sigma_m**2, math.radians(sigma_deg) ** 2]))


def seen(marker: Pose, pose: Pose, facing: bool = True) -> Observation:
    """A noise-free sighting of `marker` from a robot at `pose`."""
    expected = PoseFilter().expected(marker, pose)
    return replace(expected, marker_id=7, facing_rad=expected.facing_rad if facing else None)


def straight(f: PoseFilter, metres: float, step: float = 0.05) -> None:
    for _ in range(round(metres / step)):
        f.predict(step, step, WHEEL_BASE)


def turn_in_place(f: PoseFilter, radians: float, steps: int = 15) -> None:
    arc = radians * WHEEL_BASE / 2 / steps
    for _ in range(steps):
        f.predict(-arc, arc, WHEEL_BASE, turned_in_place=True)


def position_error(f: PoseFilter, truth: Pose) -> float:
    return math.hypot(f.pose.x - truth.x, f.pose.y - truth.y)


# Prediction.


def test_prediction_integrates_as_the_odometry_does() -> None:
    f = PoseFilter(Pose(1.0, 2.0, 0.3))
    f.predict(0.10, 0.12, WHEEL_BASE)
    turn = 0.02 / WHEEL_BASE
    mid = 0.3 + turn / 2
    assert f.pose.x == pytest.approx(1.0 + 0.11 * math.cos(mid), abs=1e-12)
    assert f.pose.y == pytest.approx(2.0 + 0.11 * math.sin(mid), abs=1e-12)
    assert f.pose.heading == pytest.approx(0.3 + turn, abs=1e-12)


def test_process_noise_grows_with_distance_whatever_the_poll_rate() -> None:
    sigmas = []
    for metres in (1.0, 2.0, 4.0, 8.0):
        f = PoseFilter(Pose())
        straight(f, metres)
        sigmas.append((f.sigma_m, f.sigma_heading))
    assert all(a[0] < b[0] and a[1] < b[1] for a, b in itertools.pairwise(sigmas))
    # 1 m: 0.01 m per wheel, so 0.007 m along the way, a heading of 0.030 rad (the
    # wheels' 0.028 and the stabilising 0.009), and across the way that heading's
    # random walk integrated: 0.030 / sqrt(3).
    heading = math.hypot(0.01 * math.sqrt(2) / WHEEL_BASE, math.radians(0.5))
    assert sigmas[0][1] == pytest.approx(heading, rel=0.01)
    assert sigmas[0][0] == pytest.approx(heading / math.sqrt(3), rel=0.05)
    f = PoseFilter(Pose())
    straight(f, 1.0)
    assert math.sqrt(f.covariance[0, 0]) == pytest.approx(0.01 / math.sqrt(2), rel=0.01)
    coarse, fine = PoseFilter(Pose()), PoseFilter(Pose())
    straight(coarse, 4.0, step=0.2)
    straight(fine, 4.0, step=0.01)
    assert fine.covariance == pytest.approx(coarse.covariance, rel=0.01, abs=1e-9)


# The filter's prior for the casters' turn after a quarter turn or more.
CASTER_MEAN = FilterNoise().caster_share * FilterNoise().caster_worst
CASTER_SIGMA = FilterNoise().caster_sigma


def test_a_turn_in_place_leaves_the_casters_turn_for_the_next_metres() -> None:
    turned = PoseFilter(Pose())
    turn_in_place(turned, math.pi / 2)
    # The same rotation, as though the casters had kept up.
    curved = PoseFilter(turned.pose, turned.covariance)
    # Nothing happens to the heading until the robot moves: the casters act then, on
    # round the way it turned (counter-clockwise here).
    assert turned.pose.heading == pytest.approx(math.pi / 2)
    assert turned.sigma_heading < math.radians(2)
    assert turned.caster_expected == pytest.approx(CASTER_MEAN)
    assert turned.caster_pending == pytest.approx(math.hypot(CASTER_MEAN, CASTER_SIGMA))
    straight(turned, 0.3)
    straight(curved, 0.3)
    # After one settling length, 1 - 1/e of the turn has come out, and with it as much
    # of its spread: the same turn, not a new one at each step.
    share = 1 - math.exp(-1)
    assert turned.pose.heading - curved.pose.heading == pytest.approx(CASTER_MEAN * share, rel=0.01)
    released = turned.covariance[2, 2] - curved.covariance[2, 2]
    assert released == pytest.approx((CASTER_SIGMA * share) ** 2, rel=0.01)
    # The robot went left of straight on as it turned.
    assert turned.pose.x < curved.pose.x - 0.02
    straight(turned, 1.5)
    straight(curved, 1.5)
    assert turned.pose.heading - curved.pose.heading == pytest.approx(CASTER_MEAN, rel=0.01)
    assert turned.sigma_heading == pytest.approx(CASTER_SIGMA, abs=math.radians(0.5))
    assert turned.caster_pending == pytest.approx(
        math.hypot(CASTER_MEAN, CASTER_SIGMA) * math.exp(-6), rel=0.01
    )
    assert turned.sigma_m > 3 * curved.sigma_m


def test_the_casters_turn_the_robot_on_the_way_it_turned() -> None:
    f = PoseFilter(Pose())
    turn_in_place(f, -math.pi / 2)  # clockwise
    assert f.caster_expected == pytest.approx(-CASTER_MEAN)
    straight(f, 3.0)
    assert f.pose.heading == pytest.approx(-math.pi / 2 - CASTER_MEAN, abs=1e-3)


def test_a_small_turn_charges_the_casters_in_proportion_and_never_past_the_worst() -> None:
    f = PoseFilter(Pose())
    turn_in_place(f, math.radians(30))
    assert f.caster_expected == pytest.approx(CASTER_MEAN / 3)
    assert f.caster_pending == pytest.approx(math.hypot(CASTER_MEAN, CASTER_SIGMA) / 3)
    # One long rotation: a caster is across after a quarter turn, and no further.
    turn_in_place(f, 2 * math.pi)
    assert f.caster_expected == pytest.approx(CASTER_MEAN)
    # Rotations apart, each swinging the casters further the same way, stop at the worst.
    for _ in range(3):
        turn_in_place(f, math.pi / 2)
        f.predict(0.01, 0.01, WHEEL_BASE)
    assert f.caster_expected <= math.radians(45.0) + 1e-9
    assert f.caster_expected > CASTER_MEAN
    assert f.caster_pending <= math.hypot(math.radians(45.0), CASTER_SIGMA) + 1e-9


def test_a_turn_back_swings_the_casters_back() -> None:
    f = PoseFilter(Pose())
    turn_in_place(f, math.pi / 2)
    turn_in_place(f, -math.pi / 2)  # the same rotation, on the spot: back where it began
    # Back on average; but each swing of a real caster is its own, so no surer.
    assert f.caster_expected == pytest.approx(0.0, abs=1e-9)
    assert f.caster_pending == pytest.approx(CASTER_SIGMA)


def test_a_sighting_after_a_turn_does_not_clear_what_the_casters_will_still_do() -> None:
    f = confident(Pose(0.0, 0.0, 0.0))
    turn_in_place(f, math.pi / 2)
    truth = f.pose
    assert f.correct(seen(WALL_MARKER, truth), WALL_MARKER)
    assert f.caster_expected == pytest.approx(CASTER_MEAN)
    straight(f, 1.0)
    assert f.sigma_heading > 0.9 * CASTER_SIGMA


def test_a_robot_placed_after_turning_to_look_still_expects_the_casters() -> None:
    f = PoseFilter()
    turn_in_place(f, math.pi / 2)  # before it knows where it is
    assert f.caster_expected == pytest.approx(CASTER_MEAN)
    f.place_from(seen(WALL_MARKER, Pose(3, 0, 1.6)), WALL_MARKER)
    placed = f.sigma_heading
    straight(f, 1.0)
    assert f.sigma_heading > math.hypot(placed, 0.9 * CASTER_SIGMA)
    assert f.pose.heading == pytest.approx(1.6 + CASTER_MEAN, abs=math.radians(2))
    f.reset(Pose())
    assert f.caster_pending == 0.0


# Correction.


@pytest.mark.parametrize("facing", [True, False])
def test_a_correction_moves_the_pose_towards_the_truth_and_shrinks_the_covariance(
    facing: bool,
) -> None:
    truth = Pose(1.0, 0.0, 0.4)
    # Known to 20 cm, and its heading to a degree: one sighting from nearly 3 m then
    # pins the distance, and the bearing the rest.
    f = PoseFilter(Pose(1.2, -0.15, 0.41), np.diag([0.2**2, 0.2**2, math.radians(1) ** 2]))
    before = f.covariance
    assert f.correct(seen(WALL_MARKER, truth, facing), WALL_MARKER)
    assert position_error(f, truth) < 0.3 * math.hypot(0.2, 0.15)
    # The heading may give a little to explain the position (the bearing ties them),
    # but stays within what the covariance says.
    e = np.array([truth.x - f.pose.x, truth.y - f.pose.y, wrap(truth.heading - f.pose.heading)])
    assert e @ np.linalg.solve(f.covariance, e) < CHI_SQUARE[0.99][3]
    assert abs(e[2]) < 2 * math.radians(1)
    assert np.linalg.det(f.covariance) < 0.1 * np.linalg.det(before)
    assert np.all(np.linalg.eigvalsh(before - f.covariance) > -1e-12)
    assert f.corrected_at == 0.0
    assert f.rejected_in_a_row == 0


def test_repeated_sightings_converge_on_the_truth() -> None:
    truth = Pose(1.0, 0.0, 0.4)
    f = PoseFilter(Pose(1.3, 0.2, 0.5), np.diag([0.3**2, 0.3**2, 0.2**2]))
    rng = np.random.default_rng(5)
    for _ in range(30):
        exact = seen(WALL_MARKER, truth)
        noisy = replace(
            exact,
            distance_m=exact.distance_m + rng.normal(0, 0.01),
            bearing_rad=exact.bearing_rad + rng.normal(0, math.radians(0.5)),
            facing_rad=exact.facing_rad + rng.normal(0, math.radians(4)),
        )
        assert f.correct(noisy, WALL_MARKER)
    # From one place, across the line of sight the position is known only as well as
    # the heading (the facings averaged: 4 degrees / sqrt(30)) times the distance.
    assert f.sigma_m < 0.06
    assert position_error(f, truth) < 3 * f.sigma_m


def test_the_measurement_model_and_its_jacobian_agree() -> None:
    f = PoseFilter(camera_forward=0.12)
    state = np.array([1.0, 2.0, 0.3, 0.2])  # the casters' turn to come is not seen
    marker = Pose(3.0, 4.0, -2.0)
    h, jac = f._model(state, marker, facing=True)
    numeric = np.zeros((3, 4))
    for i in range(4):
        d = np.zeros(4)
        d[i] = 1e-6
        numeric[:, i] = (f._model(state + d, marker, True)[0] - h) / 1e-6
    assert jac == pytest.approx(numeric, abs=1e-5)


def test_the_gate_rejects_a_marker_moved_a_metre_along_its_wall_and_is_not_dragged() -> None:
    truth = Pose(3.0, 0.2, math.pi / 2)
    moved = Pose(4.0, 2.0, -math.pi / 2)  # where it really hangs; the plan still says 3, 2
    f = confident(truth)
    pose, covariance = f.pose, f.covariance
    for _ in range(3):
        assert not f.correct(seen(moved, truth), WALL_MARKER)
    assert f.pose == pose
    assert np.array_equal(f.covariance, covariance)
    assert f.rejected_in_a_row == 3
    assert f.last_mahalanobis > f.gate(3) == CHI_SQUARE[0.99][3] == 11.345
    # Without the facing, distance and bearing alone give it away as well.
    assert not f.correct(seen(moved, truth, facing=False), WALL_MARKER)
    assert f.last_mahalanobis > f.gate(2)
    # A good sighting is accepted, and the run of rejections ends.
    assert f.mahalanobis(seen(WALL_MARKER, truth), WALL_MARKER) < 1e-9
    assert f.correct(seen(WALL_MARKER, truth), WALL_MARKER)
    assert f.rejected_in_a_row == 0


def test_the_gate_is_wide_while_the_filter_is_unsure() -> None:
    truth = Pose(3.0, 0.2, math.pi / 2)
    moved = Pose(4.0, 2.0, -math.pi / 2)
    lost = PoseFilter(truth, np.diag([1.5**2, 1.5**2, 0.5**2]))
    assert lost.correct(seen(moved, truth), WALL_MARKER)


def test_the_gate_accepts_good_noisy_sightings_at_its_confidence() -> None:
    rng = np.random.default_rng(11)
    noise = FilterNoise()
    truth = Pose(3.0, 0.2, math.pi / 2)
    accepted = 0
    for _ in range(1000):
        f = confident(truth)
        exact = seen(WALL_MARKER, truth)
        r = exact.distance_m
        noisy = replace(
            exact,
            distance_m=r + rng.normal(0, noise.distance + noise.distance_fraction * r),
            bearing_rad=exact.bearing_rad + rng.normal(0, noise.bearing),
            facing_rad=exact.facing_rad + rng.normal(0, noise.facing),
        )
        accepted += f.correct(noisy, WALL_MARKER)
    assert accepted >= 980


# Placing the robot without a prior.


@pytest.mark.parametrize("camera_forward", [0.0, 0.15])
@pytest.mark.parametrize(
    "truth",
    [
        Pose(3.0, 0.5, math.pi / 2),  # straight in front
        Pose(1.5, 0.8, 1.1),  # from the left, at an angle
        Pose(4.2, 1.0, math.radians(160)),  # close, the marker at the edge of the view
        Pose(3.5, -1.5, math.radians(95)),  # far
    ],
)
def test_place_from_recovers_the_pose_from_one_noise_free_sighting(
    truth: Pose, camera_forward: float
) -> None:
    f = PoseFilter(camera_forward=camera_forward)
    assert not f.placed
    sighting = PoseFilter(camera_forward=camera_forward).expected(WALL_MARKER, truth)
    placed = f.place_from(sighting, WALL_MARKER)
    assert placed.x == pytest.approx(truth.x, abs=1e-9)
    assert placed.y == pytest.approx(truth.y, abs=1e-9)
    assert wrap(placed.heading - truth.heading) == pytest.approx(0.0, abs=1e-9)
    assert f.placed
    assert np.all(np.linalg.eigvalsh(f.covariance) > 0)
    noise = FilterNoise()
    assert f.sigma_heading == pytest.approx(math.hypot(noise.facing, noise.marker_facing))
    # Across the line of sight the heading's error tells, times the distance.
    assert f.sigma_m == pytest.approx(sighting.distance_m * 0.105, rel=0.15, abs=0.03)


def test_place_from_puts_a_noisy_sighting_within_its_own_covariance() -> None:
    rng = np.random.default_rng(3)
    noise = FilterNoise()
    truth = Pose(2.0, 0.3, 1.3)
    nees = []
    for _ in range(2000):
        exact = seen(WALL_MARKER, truth)
        r = exact.distance_m
        noisy = replace(
            exact,
            distance_m=r + rng.normal(0, math.hypot(noise.distance + noise.distance_fraction * r,
                                                    noise.marker_position)),
            bearing_rad=exact.bearing_rad + rng.normal(0, noise.bearing),
            facing_rad=exact.facing_rad + rng.normal(0, math.hypot(noise.facing,
                                                                   noise.marker_facing)),
        )  # fmt: skip
        f = PoseFilter()
        f.place_from(noisy, WALL_MARKER)
        e = np.array([truth.x - f.pose.x, truth.y - f.pose.y, wrap(truth.heading - f.pose.heading)])
        nees.append(e @ np.linalg.solve(f.covariance, e))
    assert 2.8 < np.mean(nees) < 3.3


def test_a_filter_with_no_prior_waits_for_its_first_sighting() -> None:
    f = PoseFilter()
    assert f.sigma_m == math.inf and f.sigma_heading == math.inf
    assert np.all(np.isinf(np.diag(f.covariance)))
    assert f.predict(0.5, 0.5, WHEEL_BASE) == Pose()
    assert not f.correct(seen(WALL_MARKER, Pose(3, 0, 1.6)), WALL_MARKER)
    # Distance and bearing alone cannot say which way the robot faces.
    assert not f.observe(seen(WALL_MARKER, Pose(3, 0, 1.6), facing=False), WALL_MARKER)
    with pytest.raises(ValueError, match="facing"):
        f.place_from(seen(WALL_MARKER, Pose(3, 0, 1.6), facing=False), WALL_MARKER)
    assert f.observe(seen(WALL_MARKER, Pose(3, 0, 1.6)), WALL_MARKER)
    assert f.placed and f.pose.x == pytest.approx(3.0)


def test_what_the_detector_could_not_estimate_is_left_out() -> None:
    truth = Pose(3.0, 0.2, math.pi / 2)
    f = confident(truth)
    exact = seen(WALL_MARKER, truth)
    assert not f.correct(replace(exact, distance_m=math.nan), WALL_MARKER)
    assert not f.correct(replace(exact, bearing_rad=math.nan), WALL_MARKER)
    assert f.pose == truth
    # Without its facing, distance and bearing still count (2 degrees of freedom).
    assert f.correct(replace(exact, facing_rad=math.nan), WALL_MARKER)
    assert f.last_mahalanobis is not None and math.isfinite(f.last_mahalanobis)
    unplaced = PoseFilter()
    assert not unplaced.observe(replace(exact, facing_rad=math.nan), WALL_MARKER)
    with pytest.raises(ValueError, match="distance"):
        unplaced.place_from(replace(exact, distance_m=math.nan), WALL_MARKER)


def test_a_floor_plan_marker_is_taken_with_its_facing_in_degrees() -> None:
    planned = SimpleNamespace(id=7, at=(3.0, 2.0), height=1.1, facing=270.0)
    assert marker_pose(planned).x == 3.0
    assert wrap(marker_pose(planned).heading - WALL_MARKER.heading) == pytest.approx(0.0)
    f = PoseFilter()
    f.place_from(seen(WALL_MARKER, Pose(3, 0, 1.6)), planned)
    assert f.pose.y == pytest.approx(0.0, abs=1e-9)


def test_the_ellipse_is_the_position_covariance() -> None:
    f = PoseFilter(Pose(), np.diag([0.01, 0.0025, 0.001]))
    major, minor, angle = f.ellipse()
    assert (major, minor) == pytest.approx((0.1, 0.05))
    assert math.sin(angle) == pytest.approx(0.0, abs=1e-9)
    assert f.sigma_m == pytest.approx(0.1)
    assert f.ellipse(2.0)[0] == pytest.approx(0.2)


# A whole run: a robot driving laps of a corridor by the filter's estimate.

CORNERS = ((0.0, 0.0), (12.0, 0.0), (12.0, 8.0), (0.0, 8.0))


def corridor_markers(spacing: float, off: float = 1.0) -> list[Pose]:
    """Markers on both walls of a corridor around the loop, `off` metres either side of
    the robot's path, facing it; the walls' markers staggered by half the spacing."""
    markers = []
    for (ax, ay), (bx, by) in zip(CORNERS, CORNERS[1:] + CORNERS[:1], strict=True):
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        nx, ny = -uy, ux  # to the left, the loop's inside
        for along in np.arange(spacing / 2, length, spacing):
            inner = along
            outer = along + spacing / 2
            markers.append(Pose(ax + inner * ux + off * nx, ay + inner * uy + off * ny,
                                math.atan2(-ny, -nx)))  # fmt: skip
            markers.append(Pose(ax + outer * ux - off * nx, ay + outer * uy - off * ny,
                                math.atan2(ny, nx)))  # fmt: skip
    return markers


@dataclass
class Run:
    """The robot's world: how its wheels and casters really behave, and what the camera
    reports. The filter only sees the wheel readings and the sightings."""

    seed: int
    # Each wheel's reading against its true travel: a slip bias (the left wheel reads
    # long, the right short) and a random walk, metres per sqrt(metre).
    bias: tuple[float, float] = (0.003, -0.002)
    wheel_noise: float = 0.004
    heading_noise: float = 0.0  # radians per sqrt(metre), unseen by the wheels
    # The casters after a turn in place: the simulator's law (sim/imperfections.py),
    # an extra turn the same way, up to `caster_deg`, settling over 0.3 m; or, with
    # `caster_sigma`, a draw about the filter's mean with that deviation (its own model).
    caster_deg: float = 35.0
    caster_sigma: float | None = None
    # The camera: 1-sigma noise of distance (metres and a fraction), bearing, facing.
    sighting_noise: tuple[float, float, float, float] = (0.01, 0.01, math.radians(0.5),
                                                         math.radians(5.0))  # fmt: skip
    with_facing: bool = True
    spacing: float = 4.0
    field_of_view: float = math.radians(40)  # either side
    sight_range: float = 4.0
    sight_every: float = 0.5  # metres of travel between two sightings
    laps: int = 3
    moved: int | None = None  # a marker that hangs 1 m along its wall from its planned place
    filter_noise: FilterNoise = field(default_factory=FilterNoise)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.plan = corridor_markers(self.spacing)
        self.markers = list(self.plan)
        if self.moved is not None:
            m = self.plan[self.moved]
            along = (-math.sin(m.heading), math.cos(m.heading))
            self.markers[self.moved] = Pose(m.x + along[0], m.y + along[1], m.heading)
        self.filter = PoseFilter(noise=self.filter_noise)
        self.truth = np.zeros(3)
        self.odometry = np.zeros(3)
        self.caster = 0.0
        self.travelled = 0.0
        self.since_sighting = 0.0
        # Per step once placed: position error, heading error, NEES, metres travelled.
        self.errors: list[tuple[float, float, float, float]] = []
        self.after_correction: list[tuple[float, float, float]] = []
        self.sightings: dict[int, list[bool]] = {}

    def sight(self) -> None:
        """The nearest marker in view, if any, as the camera would report it."""
        x, y, heading = self.truth
        best = None
        for i, m in enumerate(self.markers):
            r = math.hypot(m.x - x, m.y - y)
            bearing = wrap(math.atan2(m.y - y, m.x - x) - heading)
            view = wrap(m.heading - math.atan2(y - m.y, x - m.x))
            in_view = 0.5 < r < self.sight_range and abs(bearing) < self.field_of_view
            if in_view and abs(view) < math.radians(70) and (best is None or r < best[0]):
                best = (r, bearing, i)
        if best is None:
            return
        r, bearing, i = best
        sd_r, sd_fraction, sd_bearing, sd_facing = self.sighting_noise
        facing = wrap(self.markers[i].heading - heading) + self.rng.normal(0, sd_facing)
        sighting = Observation(
            i,
            r + self.rng.normal(0, sd_r + sd_fraction * r),
            bearing + self.rng.normal(0, sd_bearing),
            facing if self.with_facing or not self.filter.placed else None,
            self.travelled,
        )
        used = self.filter.observe(sighting, self.plan[i])
        self.sightings.setdefault(i, []).append(used)
        if used:
            estimate = self.filter.pose
            self.after_correction.append(
                (
                    math.hypot(estimate.x - x, estimate.y - y),
                    abs(wrap(estimate.heading - heading)),
                    self.travelled,
                )
            )

    def move(self, left: float, right: float, in_place: bool = False) -> None:
        """The wheels truly turn by `left` and `right`; the filter gets their readings."""
        rng = self.rng
        read_left = left * (1 + self.bias[0]) + rng.normal(0, self.wheel_noise * abs(left) ** 0.5)
        read_right = right * (1 + self.bias[1]) + rng.normal(
            0, self.wheel_noise * abs(right) ** 0.5
        )
        distance = (left + right) / 2
        turn = (right - left) / WHEEL_BASE
        turn += rng.normal(0, self.heading_noise * abs(distance) ** 0.5)
        if not in_place and self.caster:
            extra = self.caster * -math.expm1(-abs(distance) / 0.3)
            self.caster -= extra
            turn += extra
        self.truth = advance(self.truth, distance, turn)
        self.odometry = advance(
            self.odometry, (read_left + read_right) / 2, (read_right - read_left) / WHEEL_BASE
        )
        self.filter.predict(read_left, read_right, WHEEL_BASE, turned_in_place=in_place)
        if not in_place:
            self.travelled += abs(distance)
            self.since_sighting += abs(distance)
            if self.since_sighting >= self.sight_every - 1e-9:
                self.since_sighting = 0.0
                self.sight()
        if self.filter.placed:
            pose = self.filter.pose
            estimate = np.array([pose.x, pose.y, pose.heading])
            e = self.truth - estimate
            e[2] = wrap(e[2])
            nees = float(e @ np.linalg.solve(self.filter.covariance, e))
            self.errors.append((math.hypot(e[0], e[1]), abs(e[2]), nees, self.travelled))

    def drive(self) -> Run:
        """Laps of the loop, steering by the estimate: turn in place to face the next
        corner, then drive to it, correcting the heading on the way."""
        self.sight()  # the robot starts facing a marker: the first sighting places it
        assert self.filter.placed
        for _ in range(self.laps):
            for gx, gy in CORNERS[1:] + CORNERS[:1]:
                est = self.filter.pose
                want = wrap(math.atan2(gy - est.y, gx - est.x) - est.heading)
                steps = max(1, int(abs(want) / math.radians(6)))
                for _ in range(steps):
                    arc = want / steps * WHEEL_BASE / 2
                    self.move(-arc, arc, in_place=True)
                share = min(1.0, abs(want) / (math.pi / 2))
                if self.caster_sigma is not None:
                    mean = self.filter_noise.caster_share * self.filter_noise.caster_worst
                    self.caster = math.copysign(share, want) * mean + self.rng.normal(
                        0, self.caster_sigma * share
                    )
                elif abs(want) > math.radians(20):
                    extra = math.radians(self.caster_deg) * share * self.rng.uniform(0.3, 1.0)
                    self.caster += math.copysign(extra, want)
                for _ in range(1000):
                    est = self.filter.pose
                    dx, dy = gx - est.x, gy - est.y
                    left_to_go = math.hypot(dx, dy)
                    if left_to_go < 0.03:
                        break
                    step = min(0.05, left_to_go)
                    off = wrap(math.atan2(dy, dx) - est.heading) if left_to_go > 0.2 else 0.0
                    turn = max(-0.1, min(0.1, off / 2))
                    self.move(step - turn * WHEEL_BASE / 2, step + turn * WHEEL_BASE / 2)
        return self

    def settled(self) -> np.ndarray:
        """The per-step errors once the first few metres have refined the placement."""
        return np.array([e for e in self.errors if e[3] > 3.0])


def advance(pose: np.ndarray, distance: float, turn: float) -> np.ndarray:
    mid = pose[2] + turn / 2
    return pose + np.array([distance * math.cos(mid), distance * math.sin(mid), turn])


def chi_square_mean_band(dof: int, samples: int, confidence: float = 0.95) -> tuple[float, float]:
    """Bounds on the mean of `samples` chi-square(dof) values (Wilson-Hilferty)."""
    k = dof * samples
    z = NormalDist().inv_cdf(0.5 + confidence / 2)

    def quantile(zp: float) -> float:
        return k * (1 - 2 / (9 * k) + zp * math.sqrt(2 / (9 * k))) ** 3

    return quantile(-z) / samples, quantile(z) / samples


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_run_with_landmarks_stays_within_5_cm_while_dead_reckoning_drifts(seed: int) -> None:
    run = Run(seed).drive()
    dead_reckoning = math.hypot(*(run.odometry[:2] - run.truth[:2]))
    assert dead_reckoning > 0.5
    assert run.travelled > 100
    corrected = np.array([c for c in run.after_correction if c[2] > 3.0])
    assert len(corrected) > 150
    assert corrected[:, 0].max() <= 0.05
    assert math.degrees(corrected[:, 1].max()) <= 3.0
    settled = run.settled()
    # Between sightings, and while the casters turn the robot after each corner, the
    # error grows for a few decimetres; most of the way it stays within 5 cm.
    assert np.percentile(settled[:, 0], 95) <= 0.05
    assert settled[:, 0].max() <= 0.2
    # Never overconfident: the error lies within the covariance's 99 % ellipsoid.
    assert np.mean(settled[:, 2] > CHI_SQUARE[0.99][3]) <= 0.01
    assert all(all(used) for used in run.sightings.values())


def test_distance_and_bearing_alone_keep_it_on_course_once_placed() -> None:
    run = Run(4, with_facing=False).drive()
    corrected = np.array([c for c in run.after_correction if c[2] > 3.0])
    assert corrected[:, 0].max() <= 0.06
    assert np.percentile(run.settled()[:, 0], 95) <= 0.05


def test_a_marker_moved_a_metre_is_rejected_every_time_and_the_run_still_holds() -> None:
    moved = 3  # on the outer wall of the first leg, passed on every lap
    run = Run(1, moved=moved).drive()
    assert len(run.sightings[moved]) >= 5
    assert not any(run.sightings[moved])
    corrected = np.array([c for c in run.after_correction if c[2] > 3.0])
    assert corrected[:, 0].max() <= 0.05
    assert np.percentile(run.settled()[:, 0], 95) <= 0.05


def test_the_filter_is_consistent_when_the_world_follows_its_model() -> None:
    """Monte Carlo: the truth drawn from the filter's own noise model (no bias, the
    casters with the filter's mean and sigma, the camera's noise as the filter assumes
    it, markers exactly where planned), markers close enough that the robot always
    sees one. The average normalised estimation error squared over the runs must then
    be 3 (the state's dimension) within a chi-square band. Each run's own average is a
    mean over correlated steps, whose spread is at most a single chi-square(3) draw's:
    so the band for `runs` independent draws is conservative."""
    noise = FilterNoise(marker_position=0.0, marker_facing=0.0)
    runs = 20
    averages = []
    for seed in range(runs):
        run = Run(
            100 + seed,
            bias=(0.0, 0.0),
            wheel_noise=noise.wheel_noise,
            heading_noise=noise.heading_noise,
            caster_sigma=noise.caster_sigma,
            sighting_noise=(noise.distance, noise.distance_fraction, noise.bearing, noise.facing),
            spacing=2.0,
            field_of_view=math.radians(45),
            sight_range=5.0,
            sight_every=0.25,
            laps=2,
            filter_noise=noise,
        ).drive()
        averages.append(np.mean([e[2] for e in run.errors]))
    low, high = chi_square_mean_band(3, runs)
    assert low < np.mean(averages) < high
