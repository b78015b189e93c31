"""The markers the robot finds itself by, and how well each is known (issue 25, §2.3.4).

"Once landmarks have been found, they must be checked against the robot's internal map.
If they are thought to be new landmarks, they are added based on the current estimated
position. If they are already known, their known position can be used to update the
current position estimate" (§2.3.4). A floor plan's markers come with how well they are
known: a tape measure's centimetre when written by hand or by `floorplan landmarks`,
what the survey found when surveyed (missions/survey.py). Each is one of:

- KNOWN: well enough (USE_SIGMA_M, USE_SIGMA_FACING) to find the robot by;
- LEARNING: seen, but not known well enough yet: a marker new to a survey, or one
  surveyed loosely. Its sightings refine it, from where the robot is known to be, until
  it is known well enough; it corrects nothing meanwhile;
- MOVED: a known marker whose sightings the pose filter's gate rejected MOVED_AFTER
  times in a row while other markers kept the robot's pose confirmed: it is not where
  the map says (someone moved it, or put it up again). It is no longer trusted; it is
  learnt afresh from where the robot is known to be, and becomes KNOWN again there.

A marker's pose is refined from a sighting only while the robot's pose is known from
others (LEARN_FROM_SIGMA_M): the marker's new pose is where that sighting puts it
(pose_graph.marker_from_sighting, the robot's covariance carried through), fused with
what was known. The robot's error at the moment is shared by every sighting from
about there, and would not average out: a marker is never taken to be known better
than the robot was when it was seen. The survey's pose graph does this properly, all
at once; this is for the robot to go on meanwhile.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from giraff_console.robot.ekf import FilterNoise, Observation, wrap
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph import marker_from_sighting

# Known this well, a marker finds the robot: a marker known to 5 cm puts a robot 2 m
# away no worse than the filter's own 5 cm look bound, and within the slow bound when
# combined with what the robot knew.
USE_SIGMA_M = 0.05
USE_SIGMA_FACING = math.radians(5.0)
# The robot must be known this well to learn a marker from where it stands: a little
# looser than the dock's 5 cm, so that a survey can start learning from there.
LEARN_FROM_SIGMA_M = 0.06
LEARN_FROM_SIGMA_HEADING = math.radians(4.0)
# Rejected this many times in a row while other markers confirm the robot: moved.
MOVED_AFTER = 5
# How the plan's own markers are taken to be known when it says nothing: put up with a
# tape measure (robot/ekf.py, FilterNoise's marker_position and marker_facing).
HAND_SIGMA_M = 0.01
HAND_SIGMA_FACING = math.radians(1.0)


class MarkerState(enum.Enum):
    KNOWN = "known"
    LEARNING = "learning"
    MOVED = "moved"


@dataclass(frozen=True)
class MarkerBelief:
    """Where a marker is believed to hang: its centre and the way its face looks (a
    Pose), the 3x3 covariance of that, its state, and how many sightings refined it."""

    pose: Pose
    covariance: np.ndarray
    state: MarkerState = MarkerState.KNOWN
    sightings: int = 0

    @property
    def sigma_m(self) -> float:
        return float(math.sqrt(max(0.0, np.linalg.eigvalsh(self.covariance[:2, :2])[-1])))

    @property
    def sigma_facing(self) -> float:
        return float(math.sqrt(max(0.0, self.covariance[2, 2])))

    @property
    def well_known(self) -> bool:
        return self.sigma_m <= USE_SIGMA_M and self.sigma_facing <= USE_SIGMA_FACING


def hand_covariance(sigma_m: float = HAND_SIGMA_M,
                    sigma_facing: float = HAND_SIGMA_FACING) -> np.ndarray:  # fmt: skip
    return np.diag([sigma_m**2, sigma_m**2, sigma_facing**2])


class MarkerMap:
    """The markers, by id; see the module docstring. `learn_new`: a marker not on the
    map is added as LEARNING when first seen (a survey); else it is ignored."""

    def __init__(self, markers: Mapping[int, MarkerBelief] | None = None, *,
                 noise: FilterNoise | None = None, learn_new: bool = False) -> None:  # fmt: skip
        self.beliefs: dict[int, MarkerBelief] = dict(markers or {})
        self.noise = noise or FilterNoise()
        self.learn_new = learn_new
        self._rejected: dict[int, int] = {}

    def __bool__(self) -> bool:
        return bool(self.beliefs)

    def __contains__(self, marker_id: object) -> bool:
        return marker_id in self.beliefs

    def known(self) -> dict[int, Pose]:
        """The markers to find the robot by, and where they hang."""
        return {i: b.pose for i, b in self.beliefs.items() if b.state is MarkerState.KNOWN}

    def usable(self, marker_id: int) -> MarkerBelief | None:
        belief = self.beliefs.get(marker_id)
        return belief if belief is not None and belief.state is MarkerState.KNOWN else None

    def learn(self, marker_id: int, robot: Pose, robot_covariance: np.ndarray,
              seen: Observation) -> str | None:  # fmt: skip
        """A sighting of a marker not to be used (new, LEARNING or MOVED) from a robot
        at `robot`, known to `robot_covariance`: refine the marker if the robot is known
        well enough (module docstring). A note when it becomes KNOWN."""
        if seen.facing_rad is None or not _known_well(robot_covariance):
            return None
        belief = self.beliefs.get(marker_id)
        if belief is None and not self.learn_new:
            return None
        if belief is not None and belief.state is MarkerState.KNOWN:
            return None
        guess = marker_from_sighting(robot, robot_covariance, seen, self.noise)
        floor = float(np.linalg.eigvalsh(robot_covariance[:2, :2])[-1])
        if belief is None:
            fused = MarkerBelief(guess.pose, guess.covariance, MarkerState.LEARNING, 1)
        else:
            fused = _fuse(belief, guess.pose, guess.covariance, floor)
        if fused.well_known and fused.sightings >= 3:
            fused = replace(fused, state=MarkerState.KNOWN)
            self.beliefs[marker_id] = fused
            how = "learnt again" if belief is not None and belief.state is MarkerState.MOVED \
                else "learnt"  # fmt: skip
            return (f"marker {marker_id} {how} at ({fused.pose.x:.2f}, {fused.pose.y:.2f}), "
                    f"±{fused.sigma_m:.2f} m: finding the robot by it")  # fmt: skip
        self.beliefs[marker_id] = fused
        return None

    def accepted(self, marker_id: int) -> None:
        """The gate took a sighting of a known marker."""
        self._rejected.pop(marker_id, None)

    def rejected(self, marker_id: int, confirmed_by_others: bool) -> str | None:
        """The gate rejected a sighting of a known marker; `confirmed_by_others`: other
        markers have just corrected the pose. A note when it is taken to have moved."""
        if not confirmed_by_others:
            return None
        count = self._rejected.get(marker_id, 0) + 1
        self._rejected[marker_id] = count
        belief = self.beliefs.get(marker_id)
        if count < MOVED_AFTER or belief is None or belief.state is not MarkerState.KNOWN:
            return None
        del self._rejected[marker_id]
        # Learnt afresh: where it hangs now is anyone's guess until seen again.
        self.beliefs[marker_id] = replace(belief, covariance=np.diag([1e4, 1e4, math.pi**2]),
                                          state=MarkerState.MOVED, sightings=0)  # fmt: skip
        return (f"marker {marker_id} is not where the plan says: its last {MOVED_AFTER} "
                "sightings disagreed with the markers round it; no longer used to find "
                "the robot, and learnt again from where it is seen")  # fmt: skip


def _known_well(covariance: np.ndarray) -> bool:
    position = float(np.linalg.eigvalsh(covariance[:2, :2])[-1])
    return position <= LEARN_FROM_SIGMA_M**2 and covariance[2, 2] <= LEARN_FROM_SIGMA_HEADING**2


def _fuse(belief: MarkerBelief, pose: Pose, covariance: np.ndarray,
          floor: float) -> MarkerBelief:  # fmt: skip
    """`belief` and a new guess of the marker's pose combined, no surer of its position
    than `floor` (a variance: the robot's, shared by the sightings from about there)."""
    prior = belief.covariance
    total = prior + covariance
    gain = prior @ np.linalg.inv(total)
    v = np.array([pose.x - belief.pose.x, pose.y - belief.pose.y,
                  wrap(pose.heading - belief.pose.heading)])  # fmt: skip
    x = np.array([belief.pose.x, belief.pose.y, belief.pose.heading]) + gain @ v
    p = (np.eye(3) - gain) @ prior
    p = (p + p.T) / 2
    smallest = float(np.linalg.eigvalsh(p[:2, :2])[0])
    if smallest < floor:
        p[:2, :2] += np.eye(2) * (floor - smallest)
    return MarkerBelief(Pose(float(x[0]), float(x[1]), wrap(float(x[2]))), p, belief.state,
                        belief.sightings + 1)  # fmt: skip
