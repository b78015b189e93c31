"""An extended Kalman filter for the robot's planar pose (§2.3.2): odometry predicts,
markers on the walls correct.

Pure: no I/O, no clock, no threads. The caller feeds it the wheels' travel between two
polls (`predict`) and each marker sighting with the marker's pose from the floor plan
(`correct`), and reads `pose`, `covariance`, `sigma_m` and `sigma_heading`.

State and motion model
    The state is (x, y, heading) in the map frame, metres and radians counter-clockwise
    from +x, as robot.odometry.Pose, and the turn the casters have still to make
    (below). A step integrates the wheels exactly as Odometry does (midpoint heading,
    turn = (right - left) / wheel base), so with no sighting and no turn on the spot
    the filter's pose is the odometry's pose.

Process noise: why these numbers
    - Each wheel's travel is off by a random walk: variance `wheel_noise**2` per metre
      that wheel turned (not a standard deviation proportional to the step: that would
      make the noise shrink as the poll rate rises, 20 small steps adding less than one
      big one). The default, 0.01 m after 1 m of a wheel's travel, is about what the
      `--imperfect` simulator's few millimetres per move (§5.5) and a real floor's slip
      add up to, and makes 10 m straight ahead cost about 5 degrees of heading.
    - The casters (§3.2.1.5): after turning in place, the swivel casters are out of line
      and "may cause the Giraff to turn up to about 45 degrees extra before they've
      finally reoriented themselves", which happens over the first decimetres of the
      next move, unseen by the wheels. "Extra" is the way the robot was turning: a
      caster swung round by the turn drags the robot on round as it swings back.
      The turn still to come is the state's fourth element. A rotation in place charges
      it by how far the casters swung: in proportion to that rotation's angle, fully
      from a quarter turn on (a caster is then across; it cannot be more). Moving
      releases it into the heading as the casters settle, the fraction
      1 - exp(-d / caster_settle) of what is left after d metres (caster_settle 0.3 m:
      about a metre to settle, as the thesis's robot did). Releasing it as the robot
      moves, not at the turn, matters: a robot that turns to look at a marker learns its
      heading then, and the casters still turn it afterwards. Being in the state, the
      turn to come is also learnt: a marker seen in the first decimetres after a turn
      shows how far the casters have turned the robot so far, and so how far they will.
      Its prior after a quarter turn or more: the way the robot turned, somewhere
      between none and about 45 degrees; so the mean is caster_share = 0.5 of
      caster_worst = 45 degrees, the middle of that, and the standard deviation
      caster_sigma = 20 degrees, wider than an even spread over it (13 degrees) so that
      a robot whose casters pull less, or more, than the thesis's is not held too sure.
      Measured against the alternatives on synthetic worlds whose casters pull up to
      15, 25, 35 and 45 degrees (tests/robot/test_ekf.py's Run, six seeds each), and on
      the imperfect simulator's patrol through every room: a zero-mean 26 degrees, as
      this filter first had, left the estimate where the wheels put it while the
      casters turned the robot 40 degrees away, and the robot steered by it into a
      door frame (room-114 on two seeds of two); 0.65 of the worst with 13 degrees
      matched the simulator but was too sure of itself on weaker casters.
    - A little heading noise per metre (`heading_noise`) is the "stabilizing noise" of
      §2.3.2, covering the linearisation and the wheel base's error.

Measurement model
    An Observation is one marker as the camera saw it: the horizontal distance from the
    camera to the marker's centre, its bearing (positive left, in the robot's frame),
    and, when the detector gives it, the direction of the marker's normal in the robot's
    frame (`facing`). The camera sits on the robot's centre line, `camera_forward` metres
    ahead of the point between the wheels (0 in the simulator, whose camera is at the
    robot's pose). The facing constrains the heading directly; without it a single
    sighting constrains only the position relative to the marker.
    With a facing, distance, bearing and facing map one to one onto a pose, so the
    update is made in pose space (the sighting's implied pose, its noise carried
    through that inverse's Jacobian): the same update as the EKF's while the estimate
    is close, and still right when it is a metre and tens of degrees off, where a
    linearisation about the estimate would not be. Without a facing, an iterated EKF
    update on distance and bearing.
    Noise: distance 2 cm + 2 % of it (solvePnP's depth from a 16 cm square), bearing
    1 degree (a pixel is 0.1 degree at 800 pixels over 90 degrees; the corners' jitter,
    the time between the frame and the poll and the head's mount make the rest), facing
    6 degrees (a planar marker's orientation is the weakest part of its pose), plus the
    marker's own placement error on the wall (1 cm, 1 degree: put up with a tape measure).

The gate
    A sighting whose innovation's squared Mahalanobis distance exceeds the chi-square
    quantile for its degrees of freedom (2 without facing, 3 with) at `gate_confidence`
    (0.99 by default: one good sighting in a hundred is dropped, which costs nothing as
    the next frame sees it again) is rejected and leaves the filter untouched. A marker
    moved 1 m along its wall but not in the plan is 1 m off in the innovation; with the
    filter confident to a few centimetres that is far beyond the gate. While the filter
    is uncertain the gate is wide, as it should be: then the sighting is the best there
    is.

No starting guess
    A filter made without a pose is not placed: `predict` and `correct` do nothing until
    `place_from` puts it where the first sighting (with its facing) says it is, with the
    covariance that sighting's noise gives. Marker ids are unique in a plan, so one
    sighting is enough.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from giraff_console.robot.odometry import Pose

# Chi-square quantiles by confidence and degrees of freedom (scipy.stats.chi2.ppf; scipy
# is not a dependency, and these are the only ones the gate needs).
CHI_SQUARE = {
    0.95: {1: 3.841, 2: 5.991, 3: 7.815},
    0.99: {1: 6.635, 2: 9.210, 3: 11.345},
    0.999: {1: 10.828, 2: 13.816, 3: 16.266},
}

# A pending caster variance below this is nothing: a micro-radian's standard deviation.
_SETTLED_RAD2 = 1e-12
# The pose's part of the state (x, y, heading, the casters' turn to come).
_POSE = np.eye(3, 4)
# Which of a measured pose's (x, y, heading) a correction fuses.
_WHOLE_POSE, _HEADING = slice(0, 3), slice(2, 3)
# How well a marker is known, where the map says: the 3x3 covariance of its centre and
# facing (metres, radians); None for the tape measure's (FilterNoise).
Sigma = np.ndarray | None


@dataclass(frozen=True)
class Observation:
    """One marker as the camera saw it: what the filter needs of a sighting. Distance and
    bearing are from the camera, `camera_forward` ahead of the wheel axle's middle;
    camera/markers.py's MarkerSighting already gives them from the axle's middle, so
    with it camera_forward is 0 and the fields carry over as they are."""

    marker_id: int
    distance_m: float  # horizontal, from the camera to the marker's centre
    bearing_rad: float  # to the marker's centre, positive left, in the robot's frame
    facing_rad: float | None  # the marker's normal in the robot's frame, if estimated
    time: float = 0.0  # when the frame was taken, on the caller's clock


@dataclass(frozen=True)
class FilterNoise:
    """The filter's noise model; the module's docstring says why these numbers."""

    wheel_noise: float = 0.01  # metres per sqrt(metre) of each wheel's travel
    heading_noise: float = math.radians(0.5)  # radians per sqrt(metre) of the centre's travel
    # The casters' extra turn after a turn in place, the same way: the worst, the share
    # of it to expect, and the spread about that.
    caster_worst: float = math.radians(45.0)
    caster_share: float = 0.5
    caster_sigma: float = math.radians(20.0)
    caster_settle: float = 0.3  # metres of travel for the casters to settle by 1 - 1/e
    distance: float = 0.02  # metres
    distance_fraction: float = 0.02  # of the distance
    bearing: float = math.radians(1.0)
    facing: float = math.radians(6.0)
    marker_position: float = 0.01  # metres: where the marker really is on the wall
    marker_facing: float = math.radians(1.0)


def _tied(p: np.ndarray) -> float:
    """The least variance the casters' turn can have, given its covariance with the
    pose, for the 4x4 covariance `p` (placed) to stay positive semi-definite."""
    cross = p[:3, 3]
    if not np.any(cross) or not np.all(np.isfinite(p[:3, :3])):
        return 0.0
    return float(cross @ np.linalg.lstsq(p[:3, :3], cross, rcond=None)[0])


def wrap(angle: float) -> float:
    """`angle` in (-pi, pi]."""
    wrapped = math.remainder(angle, math.tau)
    return math.pi if wrapped == -math.pi else wrapped


def marker_pose(marker: Any) -> Pose:
    """A marker's pose in the map as the filter takes it: its centre on the wall, and its
    normal's direction in radians. Takes a Pose as it is, or a floor plan's marker
    (`at` in metres, `facing` in degrees, planning/floorplan.py)."""
    if isinstance(marker, Pose):
        return marker
    x, y = marker.at
    return Pose(float(x), float(y), math.radians(marker.facing))


def usable(sighting: Observation) -> Observation | None:
    """The sighting as the filter can use it: None without a positive distance and a
    bearing, and without its facing when that is unknown (the detector reports NaN
    for what it could not estimate, camera/markers.py)."""
    if not sighting.distance_m > 0 or not math.isfinite(sighting.bearing_rad):
        return None
    if sighting.facing_rad is not None and not math.isfinite(sighting.facing_rad):
        return replace(sighting, facing_rad=None)
    return sighting


class PoseFilter:
    """The pose (x, y, heading) and its covariance, from odometry and marker sightings."""

    def __init__(
        self,
        pose: Pose | None = None,
        covariance: np.ndarray | None = None,
        *,
        noise: FilterNoise | None = None,
        camera_forward: float = 0.0,
        gate_confidence: float = 0.99,
        iterations: int = 3,
    ) -> None:
        if gate_confidence not in CHI_SQUARE:
            raise ValueError(f"gate confidence must be one of {sorted(CHI_SQUARE)}")
        if iterations < 1:
            raise ValueError("at least one iteration")
        self.noise = noise or FilterNoise()
        self.camera_forward = camera_forward
        self.gate_confidence = gate_confidence
        # Sightings without a facing take an iterated EKF update: relinearising the
        # distance and bearing about the updated state costs microseconds and keeps a
        # correction made with decimetres of uncertainty from overshooting.
        self.iterations = iterations
        # The state (x, y, heading, the casters' turn to come) and its 4x4 covariance. Until
        # the filter is placed only the casters' part is known (they turn the robot
        # whether or not it knows where it is); the pose's is NaN.
        self._x = np.zeros(4)
        self._p = np.zeros((4, 4))
        self._p[:3, :3] = np.nan
        self.placed = False
        # The rotation in place under way: its angle so far, net and swept, and what it
        # has charged the casters' turn to come with so far, mean and variance (see
        # _charge_casters).
        self._rotation: tuple[float, float, float, float] | None = None
        # The last sighting's squared Mahalanobis distance, how many sightings in a row
        # the gate has rejected (a robot that keeps rejecting every marker it sees is
        # more likely lost than surrounded by misread ones: the caller's to judge, and
        # place_from starts again), and the time of the last one used.
        self.last_mahalanobis: float | None = None
        self.rejected_in_a_row = 0
        self.corrected_at: float | None = None
        if pose is not None:
            self.reset(pose, covariance)

    # The estimate.

    @property
    def pose(self) -> Pose:
        """The estimate; the origin facing +x while not placed."""
        x = self._x  # one read: every step replaces the array, never writes into it
        return Pose(float(x[0]), float(x[1]), float(x[2]))

    @property
    def covariance(self) -> np.ndarray:
        """The 3x3 covariance of (x, y, heading), a copy; infinite while not placed."""
        if not self.placed:
            return np.diag([np.inf, np.inf, np.inf])
        return self._p[:3, :3].copy()

    @property
    def sigma_m(self) -> float:
        """The position's standard deviation along its worst direction: the square root of
        the position covariance's larger eigenvalue (the 1-sigma ellipse's semi-major
        axis), so that "within sigma_m" holds whichever way the error lies."""
        if not self.placed:
            return math.inf
        return float(math.sqrt(max(0.0, np.linalg.eigvalsh(self._p[:2, :2])[-1])))

    @property
    def sigma_heading(self) -> float:
        """The heading's standard deviation, radians (the casters' pending turn is not in
        it until the robot moves)."""
        if not self.placed:
            return math.inf
        return float(math.sqrt(max(0.0, self._p[2, 2])))

    @property
    def caster_pending(self) -> float:
        """The root mean square (radians) of the heading change the casters have still
        to make since the last turn in place: how much they may yet turn the robot."""
        x, p = self._x, self._p
        return math.sqrt(x[3] ** 2 + max(0.0, p[3, 3]))

    @property
    def caster_rate(self) -> float:
        """How fast the casters are expected to turn the robot now: radians per metre
        driven, positive left (the release's slope where the robot is)."""
        return float(self._x[3]) / self.noise.caster_settle

    @property
    def caster_expected(self) -> float:
        """The heading change (radians, counter-clockwise) the casters are expected to
        make yet: the pending turn's mean."""
        return float(self._x[3])

    def ellipse(self, k: float = 1.0) -> tuple[float, float, float]:
        """The position's k-sigma ellipse: semi-major and semi-minor axes in metres, and
        the major axis's direction in radians from +x, for drawing."""
        if not self.placed:
            return math.inf, math.inf, 0.0
        values, vectors = np.linalg.eigh(self._p[:2, :2])
        major, minor = (k * math.sqrt(max(0.0, v)) for v in values[::-1])
        return major, minor, math.atan2(vectors[1, 1], vectors[0, 1])

    def reset(self, pose: Pose, covariance: np.ndarray | None = None) -> None:
        """Start again from `pose`, known to `covariance` (exactly, without one), with
        the casters in line."""
        self._set_pose(pose, covariance, 0.0, 0.0)
        self._rotation = None

    def inflate(self, extra: np.ndarray) -> None:
        """Know the pose less well by `extra` (a 3x3 covariance added to the pose's):
        something happened that the motion model does not cover, such as a contact."""
        if not self.placed:
            return
        p = self._p.copy()
        p[:3, :3] += np.asarray(extra, dtype=float)
        self._p = (p + p.T) / 2

    def move_to(self, pose: Pose) -> None:
        """The estimate is now `pose`, known as well as it was, the casters' turn to come
        kept: the odometry's own pose jumped, and the estimate with it."""
        x = self._x.copy()
        x[:3] = pose.x, pose.y, pose.heading
        self._x = x

    def relocate(self, pose: Pose, covariance: np.ndarray) -> None:
        """The estimate is now `pose`, known to `covariance`, by what knows better than
        the filter (a survey's graph, robot/pose_graph.py), the casters' turn to come kept."""
        self._set_pose(pose, covariance, float(self._x[3]), float(self._p[3, 3]))

    def _set_pose(self, pose: Pose, covariance: np.ndarray | None, caster: float,
                  caster_var: float) -> None:  # fmt: skip
        """The pose known to `covariance`, and the casters' turn to come to `caster_var`,
        independent of it."""
        p = np.zeros((3, 3)) if covariance is None else np.array(covariance, dtype=float)
        if p.shape != (3, 3):
            raise ValueError("the covariance must be 3x3")
        self._x = np.array([pose.x, pose.y, pose.heading, caster], dtype=float)
        full = np.zeros((4, 4))
        full[:3, :3] = (p + p.T) / 2
        full[3, 3] = caster_var
        self._p = full
        self.placed = True
        self.rejected_in_a_row = 0

    # Odometry.

    def predict(
        self, left_m: float, right_m: float, wheel_base: float, turned_in_place: bool = False
    ) -> Pose:
        """Move the estimate by what the wheels did since the last step (as Odometry.update
        integrates it), and grow the covariance by the wheels' noise, the stabilising
        noise and whatever the casters turn. `turned_in_place` says the step was a rotation
        on the spot (a rotate move), which leaves the casters out of line. Before the
        filter is placed, only the casters' part moves on."""
        if not wheel_base > 0:
            raise ValueError("the wheel base must be positive")
        noise = self.noise
        distance = (left_m + right_m) / 2
        turn = (right_m - left_m) / wheel_base
        # Moving releases this share of the casters' turn to come into the heading.
        share = -math.expm1(-abs(distance) / noise.caster_settle) if distance else 0.0
        if not self.placed:
            # The casters turn the robot whether or not it knows where it is.
            state, p = self._x.copy(), self._p.copy()
            state[3] *= 1 - share
            p[3, 3] *= (1 - share) ** 2
            self._x, self._p = state, p
        else:
            x, y, heading, caster = self._x
            turned = turn + share * caster
            mid = heading + turned / 2
            cos_mid, sin_mid = math.cos(mid), math.sin(mid)
            self._x = np.array([x + distance * cos_mid, y + distance * sin_mid,
                                heading + turned, caster * (1 - share)])  # fmt: skip
            # Jacobians of the step with respect to the state and to the wheels' travels
            # (leaving out how the share released depends on the travel: the casters'
            # turn is all released in the end whatever the steps, so that only moves
            # when, by a fraction of a step).
            half = share / 2
            f = np.array(
                [
                    [1.0, 0.0, -distance * sin_mid, -distance * sin_mid * half],
                    [0.0, 1.0, distance * cos_mid, distance * cos_mid * half],
                    [0.0, 0.0, 1.0, share],
                    [0.0, 0.0, 0.0, 1.0 - share],
                ]
            )
            two_bases = 2 * wheel_base
            w = np.array(
                [
                    [cos_mid / 2 + distance * sin_mid / two_bases,
                     cos_mid / 2 - distance * sin_mid / two_bases],
                    [sin_mid / 2 - distance * cos_mid / two_bases,
                     sin_mid / 2 + distance * cos_mid / two_bases],
                    [-1.0 / wheel_base, 1.0 / wheel_base],
                    [0.0, 0.0],
                ]
            )  # fmt: skip
            wheels = np.diag([noise.wheel_noise**2 * abs(left_m),
                              noise.wheel_noise**2 * abs(right_m)])  # fmt: skip
            p = f @ self._p @ f.T + w @ wheels @ w.T
            p[2, 2] += noise.heading_noise**2 * abs(distance)
            self._p = (p + p.T) / 2
        self._settle_casters()
        if turned_in_place and turn != 0.0:
            self._charge_casters(turn)
        elif distance != 0.0:
            self._rotation = None  # moving on ends a rotation in place
        return self.pose

    def _settle_casters(self) -> None:
        """Casters within a micro-radian of their turn, to a micro-radian, are in line."""
        x, p = self._x, self._p
        if x[3] != 0.0 and abs(x[3]) < 1e-6 and p[3, 3] < _SETTLED_RAD2:
            x, p = x.copy(), p.copy()
            x[3] = 0.0
            p[3, :] = p[:, 3] = 0.0
            self._x, self._p = x, p

    def _charge_casters(self, turn: float) -> None:
        """A step of a rotation in place: the casters swing further round, the same way
        (after the release, so that a rotation does not settle its own casters). What
        the rotation charges follows its net angle so far, so a rotation back swings
        them back on average; how sure that is follows the angle swept, so it never
        grows surer by turning (each swing of a real caster is its own)."""
        noise = self.noise
        angle, swept, charged, charged_var = self._rotation or (0.0, 0.0, 0.0, 0.0)
        angle += turn
        swept += abs(turn)
        swung = min(1.0, abs(angle) / (math.pi / 2))
        charge = math.copysign(noise.caster_share * noise.caster_worst * swung, angle)
        charge_var = (noise.caster_sigma * min(1.0, swept / (math.pi / 2))) ** 2
        self._rotation = (angle, swept, charge, charge_var)
        x, p = self._x.copy(), self._p.copy()
        worst = noise.caster_worst
        x[3] = max(-worst, min(worst, x[3] + charge - charged))
        # The swing is independent of all before it: its variance adds to the casters'
        # alone, never below what their ties to the pose need for the covariance to
        # stay positive, nor past one full swing's spread (a caster cannot be further
        # out than across), which scales their row and column down.
        p[3, 3] = max(p[3, 3] + charge_var - charged_var, _tied(p))
        if p[3, 3] > noise.caster_sigma**2:
            scale = noise.caster_sigma / math.sqrt(p[3, 3])
            p[3, :] *= scale
            p[:, 3] *= scale
        self._x, self._p = x, p

    # Sightings.

    def _measurement_noise(self, distance: float, facing: bool,
                           sigma: Sigma = None) -> np.ndarray:  # fmt: skip
        """The sighting's noise, and the marker's own on its wall: the tape measure's
        (FilterNoise), unless `sigma` (the marker's covariance, where the map says how
        well it is known) is given, which the caller carries through its own model."""
        n = self.noise
        distance = max(distance, 1e-3)
        position, turned = (n.marker_position, n.marker_facing) if sigma is None else (0.0, 0.0)
        r = [
            (n.distance + n.distance_fraction * distance) ** 2 + position**2,
            n.bearing**2 + (position / distance) ** 2,
        ]
        if facing:
            r.append(n.facing**2 + turned**2)
        return np.diag(r)

    def _marker_noise(self, sigma: np.ndarray, by_marker: np.ndarray) -> np.ndarray:
        """A marker's own covariance `sigma`, no better than the tape measure's, through
        `by_marker` (the Jacobian of what is measured by the marker's x, y, facing)."""
        n = self.noise
        floor = np.diag([n.marker_position**2, n.marker_position**2, n.marker_facing**2])
        known = np.asarray(sigma, dtype=float)
        known = known + np.diag(np.maximum(np.diag(floor) - np.diag(known), 0.0))
        return by_marker @ known @ by_marker.T

    def expected(self, marker: Any, pose: Pose | None = None) -> Observation:
        """What a camera on the robot at `pose` (the estimate by default) would see of
        `marker`: the measurement model, for the caller's own checks and for tests."""
        at = marker_pose(marker)
        x = self._x[:3] if pose is None else np.array([pose.x, pose.y, pose.heading])
        h, _ = self._model(x, at, facing=True)
        return Observation(-1, float(h[0]), float(h[1]), float(h[2]))

    def _model(
        self, state: np.ndarray, marker: Pose, facing: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """The predicted measurement at `state` and its Jacobian (with respect to the
        whole state: none of it depends on the casters' turn to come)."""
        x, y, heading = state[:3]
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        forward = self.camera_forward
        dx = marker.x - (x + forward * cos_h)
        dy = marker.y - (y + forward * sin_h)
        q = max(dx * dx + dy * dy, 1e-12)
        r = math.sqrt(q)
        h = [r, wrap(math.atan2(dy, dx) - heading)]
        jac = [
            [-dx / r, -dy / r, forward * (dx * sin_h - dy * cos_h) / r, 0.0],
            [dy / q, -dx / q, -forward * (dy * sin_h + dx * cos_h) / q - 1.0, 0.0],
        ]
        if facing:
            h.append(wrap(marker.heading - heading))
            jac.append([0.0, 0.0, -1.0, 0.0])
        return np.array(h), np.array(jac)

    @staticmethod
    def _innovation(z: np.ndarray, h: np.ndarray) -> np.ndarray:
        v = z - h
        v[1:] = [wrap(angle) for angle in v[1:]]
        return v

    def gate(self, dof: int) -> float:
        """The squared Mahalanobis distance beyond which a sighting is rejected."""
        return CHI_SQUARE[self.gate_confidence][dof]

    def mahalanobis(self, sighting: Observation, marker: Any, sigma: Sigma = None) -> float:
        """The sighting's squared Mahalanobis distance from what the estimate expects, as
        the gate computes it (3 degrees of freedom with a facing, 2 without)."""
        seen = usable(sighting)
        if not self.placed or seen is None:
            return math.inf
        at = marker_pose(marker)
        if seen.facing_rad is not None:
            v, s, _ = self._pose_innovation(seen, at, sigma)
        else:
            v, s, _ = self._range_bearing_innovation(seen, at, self._x, sigma)
        return float(v @ np.linalg.solve(s, v))

    def correct(self, sighting: Observation, marker: Any, sigma: Sigma = None) -> bool:
        """Correct the estimate by one sighting of `marker` (its pose in the map, or a
        floor plan's marker), known to `sigma` (metres, radians; the tape measure's by
        default). False, and the filter untouched, when the gate rejects it or the
        filter is not placed yet (see place_from)."""
        seen = usable(sighting)
        if not self.placed or seen is None:
            return False
        at = marker_pose(marker)
        if seen.facing_rad is not None:
            return self._correct_pose(seen, at, sigma)
        return self._correct_range_bearing(seen, at, sigma)

    def _accept(self, v: np.ndarray, s: np.ndarray) -> bool:
        d2 = float(v @ np.linalg.solve(s, v))
        self.last_mahalanobis = d2
        if d2 <= self.gate(len(v)):
            return True
        self.rejected_in_a_row += 1
        return False

    def _update(self, state: np.ndarray, p: np.ndarray, time: float) -> None:
        self._x = state
        self._p = (p + p.T) / 2
        self.rejected_in_a_row = 0
        self.corrected_at = time

    def _pose_innovation(
        self, sighting: Observation, at: Pose, sigma: Sigma
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pose the sighting implies less the estimate, its covariance, and the
        sighting's own covariance in pose space."""
        measured, noise = self._implied_pose(sighting, at, sigma)
        return *self._pose_residual(measured, noise), noise

    def _pose_residual(self, measured: np.ndarray, noise: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """A measured pose less the estimate, and its covariance."""
        v = measured - self._x[:3]
        v[2] = wrap(v[2])
        return v, self._p[:3, :3] + noise

    def _correct_pose(self, sighting: Observation, at: Pose, sigma: Sigma) -> bool:
        """A sighting with its facing gives the whole pose (place_from's inverse), so the
        update is made in pose space, where the measurement is the pose itself (H = [I 0])
        with the noise mapped through the inverse's Jacobian at the measured values. In
        the linear regime this is the EKF's update exactly (pose and measurement map one
        to one, so both carry the same information); unlike it, it does not linearise
        about the estimate, which after a long blind stretch with the casters' heading
        error can be a metre and tens of degrees off, where the linearised gate would
        reject every good sighting and the robot would stay lost."""
        measured, noise = self._implied_pose(sighting, at, sigma)
        return self._measured_pose(measured, noise, sighting.time)

    def correct_pose(self, measured: Pose, noise: np.ndarray, time: float) -> bool:
        """Correct the estimate by a measurement of the whole pose (a range scan fitted
        to the map, robot/localisation.py), known to `noise` (3x3: metres, radians),
        taken at `time`. False, and the filter untouched, when the gate rejects it or the
        filter is not placed yet."""
        if not self.placed:
            return False
        return self._measured_pose(np.array([measured.x, measured.y, measured.heading]),
                                   noise, time)  # fmt: skip

    def correct_heading(self, measured: Pose, noise: np.ndarray, time: float) -> bool:
        """Correct the heading alone by a measurement of the whole pose, known to `noise`
        (3x3, as correct_pose's), taken at `time`: for a position already known better
        than the measurement's source is drawn (robot/localisation.py's SCAN_FLOOR_M).
        The whole pose is gated, as correct_pose gates it; the position moves only as
        far as it is tied to the heading. False, and the filter untouched, when the gate
        rejects it or the filter is not placed yet."""
        if not self.placed:
            return False
        return self._measured_pose(np.array([measured.x, measured.y, measured.heading]),
                                   noise, time, _HEADING)  # fmt: skip

    def agrees(self, measured: Pose, noise: np.ndarray) -> bool:
        """Whether a measurement of the whole pose, known to `noise`, passes the gate
        correct_pose would weigh it with; the filter untouched."""
        if not self.placed:
            return False
        v, s = self._pose_residual(np.array([measured.x, measured.y, measured.heading]), noise)
        return float(v @ np.linalg.solve(s, v)) <= self.gate(len(v))

    def _measured_pose(self, measured: np.ndarray, noise: np.ndarray, time: float,
                       fused: slice = _WHOLE_POSE) -> bool:  # fmt: skip
        """The whole pose `measured`, gated; the `fused` part of it corrects the state."""
        v, s = self._pose_residual(measured, noise)
        if not self._accept(v, s):
            return False
        p, h, r = self._p, _POSE[fused], noise[fused, fused]
        # The casters' turn to come is corrected too, by its covariance with the pose.
        gain = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
        keep = np.eye(4) - gain @ h
        # Joseph form: stays symmetric and positive definite whatever the rounding.
        self._update(self._x + gain @ v[fused], keep @ p @ keep.T + gain @ r @ gain.T, time)
        return True

    def _range_bearing_innovation(
        self, sighting: Observation, at: Pose, state: np.ndarray, sigma: Sigma
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Measured less expected distance and bearing at `state`, the innovation's
        covariance, and the Jacobian."""
        z = np.array([sighting.distance_m, sighting.bearing_rad])
        h, jac = self._model(state, at, facing=False)
        noise = self._range_bearing_noise(sighting, at, state, sigma)
        return self._innovation(z, h), jac @ self._p @ jac.T + noise, jac

    def _range_bearing_noise(self, sighting: Observation, at: Pose, state: np.ndarray,
                             sigma: Sigma) -> np.ndarray:  # fmt: skip
        """Distance and bearing's noise, the marker's own carried through the model."""
        noise = self._measurement_noise(sighting.distance_m, False, sigma)
        if sigma is None:
            return noise
        # The distance and bearing move with the marker as they move against the robot.
        _, jac = self._model(state, at, facing=False)
        return noise + self._marker_noise(sigma, -jac[:, :3] @ np.diag([1.0, 1.0, 0.0]))

    def _correct_range_bearing(self, sighting: Observation, at: Pose, sigma: Sigma) -> bool:
        """Distance and bearing only: an iterated EKF update (Gauss-Newton), relinearising
        the measurement about the latest state x_i, each time from the prior x_0:
        x_i+1 = x_0 + K_i (z - h(x_i) - H_i (x_0 - x_i))."""
        prior, p = self._x, self._p
        v, s, jac = self._range_bearing_innovation(sighting, at, prior, sigma)
        if not self._accept(v, s):
            return False
        state = prior
        for i in range(self.iterations):
            if i > 0:
                v, s, jac = self._range_bearing_innovation(sighting, at, state, sigma)
            gain = p @ jac.T @ np.linalg.inv(s)
            state = prior + gain @ (v - jac @ (prior - state))
        noise = self._range_bearing_noise(sighting, at, state, sigma)
        keep = np.eye(4) - gain @ jac
        self._update(state, keep @ p @ keep.T + gain @ noise @ gain.T, sighting.time)
        return True

    def _implied_pose(self, sighting: Observation, at: Pose,
                      sigma: Sigma = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """The robot's pose as one sighting with its facing says, and its covariance."""
        assert sighting.facing_rad is not None
        r, bearing, facing = sighting.distance_m, sighting.bearing_rad, sighting.facing_rad
        forward = self.camera_forward
        heading = wrap(at.heading - facing)
        towards = heading + bearing  # from the camera to the marker, in the map
        cos_t, sin_t = math.cos(towards), math.sin(towards)
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        pose = np.array(
            [at.x - r * cos_t - forward * cos_h, at.y - r * sin_t - forward * sin_h, heading]
        )
        # d(x, y, heading) / d(distance, bearing, facing).
        jac = np.array(
            [
                [-cos_t, r * sin_t, -r * sin_t - forward * sin_h],
                [-sin_t, -r * cos_t, r * cos_t + forward * cos_h],
                [0.0, 0.0, -1.0],
            ]
        )
        noise = jac @ self._measurement_noise(r, True, sigma) @ jac.T
        if sigma is not None:
            # The pose implied moves with the marker: its centre one for one, and round
            # it as its facing turns.
            by_marker = np.array([
                [1.0, 0.0, r * sin_t + forward * sin_h],
                [0.0, 1.0, -r * cos_t - forward * cos_h],
                [0.0, 0.0, 1.0],
            ])  # fmt: skip
            noise = noise + self._marker_noise(sigma, by_marker)
        return pose, noise

    def place_from(self, sighting: Observation, marker: Any, sigma: Sigma = None) -> Pose:
        """Put the robot where one sighting of `marker` says it is, whatever was known
        before: the inverse of the marker's pose as seen, with the covariance the
        sighting's noise gives it. Needs the sighting's facing: without it the heading,
        and so where around the marker the robot stands, is unknown."""
        checked = usable(sighting)
        if checked is None:
            raise ValueError("placing the robot needs a positive distance and a bearing")
        if checked.facing_rad is None:
            raise ValueError("placing the robot needs the marker's facing")
        sighting = checked
        pose, covariance = self._implied_pose(sighting, marker_pose(marker), sigma)
        # The sighting says nothing of the casters: a robot that turned to find a
        # marker still has their turn to come.
        self._set_pose(Pose(*pose), covariance, float(self._x[3]), float(self._p[3, 3]))
        self.corrected_at = sighting.time
        return self.pose

    def observe(self, sighting: Observation, marker: Any) -> bool:
        """Place the robot from the sighting if the filter is not placed yet (and the
        sighting has a facing), else correct by it. True if it was used."""
        if not self.placed:
            checked = usable(sighting)
            if checked is None or checked.facing_rad is None:
                return False
            self.place_from(checked, marker)
            return True
        return self.correct(sighting, marker)
