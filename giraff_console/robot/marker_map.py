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

Markers hang on walls, and the plan knows its walls. Learnt from a robot that has come
a long way, a marker is off by what the robot's heading drifted: 14 cm across a
corridor 35 m from the dock, measured on the imperfect simulator, enough to clip the
next 0.9 m doorway. So a marker being learnt within WALL_SNAP_M of a wall of the plan
that it faces out of (`walls`) is held to it, as the survey's solver holds it
(robot/survey_walls.py): on its line to WALL_SIGMA_M, facing its normal to
WALL_SIGMA_FACING. Across the wall is then known from the plan; along it, from the
sightings.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from giraff_console.robot.ekf import FilterNoise, Observation, wrap
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph import marker_from_sighting

Point = tuple[float, float]

# Known this well, a marker finds the robot: a marker 2 m away known to 8 cm and 6
# degrees puts the robot within the slow bound (certainty.py's 0.10 m), and the filter
# takes the marker's own uncertainty into the sighting's (ekf.py), so it is never
# surer of the robot than of the marker. A survey starting on the dock (5 cm) learns
# its first markers a little looser than that, and must be able to go by them.
USE_SIGMA_M = 0.08
USE_SIGMA_FACING = math.radians(6.0)
# The robot must be known this well to learn a marker from where it stands: a little
# looser than the dock's 5 cm, so that a survey can start learning from there...
LEARN_FROM_SIGMA_M = 0.06
LEARN_FROM_SIGMA_HEADING = math.radians(4.0)
# ...or this well, for a marker that lands on a wall of the plan, which then says where
# it is across the wall and which way it faces: what holds the robot's heading, whose
# drift is what loses it (the casters' unseen turns, §3.2.1.5). Along the wall it is
# known only as well as the robot was.
LEARN_ON_WALL_SIGMA_M = 0.5
LEARN_ON_WALL_SIGMA_HEADING = math.radians(30.0)
# A marker known this loosely along its worst direction is not used at all, however
# well across it: the gate round it would let anything through.
LOOSEST_M = 1.0
# Rejected this many times in a row while other markers confirm the robot: moved.
MOVED_AFTER = 5
# A marker this near a wall of the plan, facing out of it within WALL_SNAP_FACING, is
# held to it (module docstring): further than a corridor's drift, nearer than a
# corridor's width.
WALL_SNAP_M = 0.3
WALL_SNAP_FACING = math.radians(20.0)
WALL_SIGMA_M = 0.02
WALL_SIGMA_FACING = math.radians(2.0)
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
        """Known well enough to correct the robot by: its facing, and its place along
        at least one direction (across its wall); the filter takes its covariance in
        (robot/ekf.py), so a marker known well across its wall and loosely along it
        corrects the heading and the distance from the wall, and little else."""
        values = np.linalg.eigvalsh(self.covariance[:2, :2])
        return (self.sigma_facing <= USE_SIGMA_FACING and values[0] <= USE_SIGMA_M**2
                and values[-1] <= LOOSEST_M**2)  # fmt: skip

    @property
    def placeable(self) -> bool:
        """Known well enough every way to place a robot that does not know where it is."""
        return self.sigma_m <= USE_SIGMA_M and self.sigma_facing <= USE_SIGMA_FACING


def hand_covariance(sigma_m: float = HAND_SIGMA_M,
                    sigma_facing: float = HAND_SIGMA_FACING) -> np.ndarray:  # fmt: skip
    return np.diag([sigma_m**2, sigma_m**2, sigma_facing**2])


def on_wall_covariance(sigma_m: float, sigma_facing: float, facing: float,
                       off_wall: float = 0.0) -> np.ndarray:  # fmt: skip
    """The covariance of a marker on a wall of the plan, `off_wall` metres from its line,
    facing `facing` (radians), as a survey wrote it: `sigma_m` along its worst direction,
    which for a marker held to its wall is along the wall; across the wall no worse
    than the plan's wall says (WALL_SIGMA_M: module docstring), or than how far from it
    the marker is written; its facing to `sigma_facing`. One figure for both ways would
    throw away the better: a survey leaves a marker in a room it saw from one side known
    to 15 cm along its wall and 2 cm across it, and as 15 cm every way it would never
    be used."""
    across = min(sigma_m, max(WALL_SIGMA_M, off_wall))
    normal = np.array([math.cos(facing), math.sin(facing)])
    along = np.array([-normal[1], normal[0]])
    covariance = np.zeros((3, 3))
    covariance[:2, :2] = sigma_m**2 * np.outer(along, along) + across**2 * np.outer(normal, normal)
    covariance[2, 2] = sigma_facing**2
    return covariance


class MarkerMap:
    """The markers, by id; see the module docstring. `learn_new`: a marker not on the
    map is added as LEARNING when first seen (a survey); else it is ignored."""

    def __init__(self, markers: Mapping[int, MarkerBelief] | None = None, *,
                 noise: FilterNoise | None = None, learn_new: bool = False,
                 walls: Sequence[tuple[Point, Point]] = ()) -> None:  # fmt: skip
        """`walls`: the plan's walls (their ends), which markers being learnt are held to."""
        self.beliefs: dict[int, MarkerBelief] = dict(markers or {})
        self.noise = noise or FilterNoise()
        self.learn_new = learn_new
        self.walls = np.array(walls, dtype=float).reshape(-1, 2, 2)
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
        if seen.facing_rad is None or not _known(robot_covariance, LEARN_ON_WALL_SIGMA_M,
                                                  LEARN_ON_WALL_SIGMA_HEADING):  # fmt: skip
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
        fused, on_wall = self._on_wall(fused)
        if not (on_wall or _known(robot_covariance, LEARN_FROM_SIGMA_M, LEARN_FROM_SIGMA_HEADING)):
            return None  # a robot this unsure learns only what a wall pins down
        if fused.well_known and fused.sightings >= 3:
            fused = replace(fused, state=MarkerState.KNOWN)
            self.beliefs[marker_id] = fused
            how = "learnt again" if belief is not None and belief.state is MarkerState.MOVED \
                else "learnt"  # fmt: skip
            return (f"marker {marker_id} {how} at ({fused.pose.x:.2f}, {fused.pose.y:.2f}), "
                    f"±{fused.sigma_m:.2f} m: finding the robot by it")  # fmt: skip
        self.beliefs[marker_id] = fused
        return None

    def redraw(self, markers: Mapping[int, MarkerBelief]) -> None:
        """These markers' poses, from a survey's graph, in place of what was learnt of
        them (missions/survey.py); rejections counted against the old ones forgotten."""
        self.beliefs.update(markers)
        for marker_id in markers:
            self._rejected.pop(marker_id, None)

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

    def _on_wall(self, belief: MarkerBelief) -> tuple[MarkerBelief, bool]:
        """`belief` held to the wall of the plan it hangs on, if one is near enough and
        it faces out of it (module docstring), and whether it was."""
        walls = self.walls
        if not len(walls):
            return belief, False
        a, b = walls[:, 0], walls[:, 1]
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        ok = length > 0
        along = d / np.where(ok, length, 1.0)[:, None]
        rel = np.array([belief.pose.x, belief.pose.y]) - a
        t = np.einsum("ij,ij->i", rel, along)
        across = rel[:, 0] * along[:, 1] - rel[:, 1] * along[:, 0]
        # The normal on the wall's right; a marker faces out of one side or the other.
        normal = np.arctan2(-along[:, 0], along[:, 1])
        facing_off = np.abs(np.angle(np.exp(1j * (belief.pose.heading - normal))))
        right = facing_off <= WALL_SNAP_FACING
        left = np.pi - facing_off <= WALL_SNAP_FACING
        near = ok & (np.abs(across) <= WALL_SNAP_M) & (t >= -0.1) & (t <= length + 0.1)
        candidates = np.flatnonzero(near & (left | right))
        if not len(candidates):
            return belief, False
        wall = candidates[np.argmin(np.abs(across[candidates]))]
        ux, uy = along[wall]
        on_line = a[wall] + t[wall] * along[wall]
        facing = float(normal[wall]) if right[wall] else wrap(float(normal[wall]) + math.pi)
        # Along the wall as the sightings say; across it and its facing as the plan does.
        rotation = np.array([[ux, -uy], [uy, ux]])
        local = rotation.T @ belief.covariance[:2, :2] @ rotation
        local[1, 1] = min(local[1, 1], WALL_SIGMA_M**2)
        local[0, 1] = local[1, 0] = 0.0
        covariance = np.zeros((3, 3))
        covariance[:2, :2] = rotation @ local @ rotation.T
        covariance[2, 2] = min(belief.covariance[2, 2], WALL_SIGMA_FACING**2)
        pose = Pose(float(on_line[0]), float(on_line[1]), float(facing))
        return replace(belief, pose=pose, covariance=covariance), True


def _known(covariance: np.ndarray, sigma_m: float, sigma_heading: float) -> bool:
    """A robot's covariance within these standard deviations."""
    position = float(np.linalg.eigvalsh(covariance[:2, :2])[-1])
    return position <= sigma_m**2 and covariance[2, 2] <= sigma_heading**2


def _fuse(belief: MarkerBelief, pose: Pose, covariance: np.ndarray,
          floor: float) -> MarkerBelief:  # fmt: skip
    """`belief` and a new guess of the marker's pose combined, no surer of its position
    along its worst direction than `floor` (a variance: the robot's, shared by the
    sightings from about there)."""
    prior = belief.covariance
    total = prior + covariance
    gain = prior @ np.linalg.inv(total)
    v = np.array([pose.x - belief.pose.x, pose.y - belief.pose.y,
                  wrap(pose.heading - belief.pose.heading)])  # fmt: skip
    x = np.array([belief.pose.x, belief.pose.y, belief.pose.heading]) + gain @ v
    p = (np.eye(3) - gain) @ prior
    p = (p + p.T) / 2
    # Along its worst direction at least: across a wall the plan may know it better.
    largest = float(np.linalg.eigvalsh(p[:2, :2])[-1])
    if largest < floor:
        p[:2, :2] += np.eye(2) * (floor - largest)
    return MarkerBelief(Pose(float(x[0]), float(x[1]), wrap(float(x[2]))), p, belief.state,
                        belief.sightings + 1)  # fmt: skip
