"""A survey's wheels and camera frames as the pose graph's keyframes, odometry edges and
sightings (pose_graph.py), thinned as they come.

Pure: no I/O, no clock, no threads. The survey mission hands `wheels` each poll's wheel
travel, as Localisation.follow hands the filter (with its turn-in-place flag), and
`frame` each camera frame's markers, moved to the present as Localisation does; `survey`
gives the graph so far.

Keyframes, and why there
    A keyframe is cut where a frame with markers comes once the robot has gone 0.25 m
    or turned 10 degrees since the last one: a marker's sightings from nearer together
    than that share most of their error (the path's, over a few centimetres), so more
    of them cost time and add little. Sooner (5 cm, 3 degrees) for a marker seen at
    neither of the last two keyframes, so that one glimpsed in passing is kept. A frame
    between keyframes is dropped, unless the robot has not moved since the last (its
    markers join that keyframe): at most one sighting per marker per keyframe. Without
    frames a keyframe is cut every metre or 45 degrees, so that no edge is long; and
    always where the robot sets off after a turn on the spot, where the casters' turn
    starts (below).

Edges
    The wheels between two keyframes are integrated step by step exactly as
    PoseFilter.predict integrates them (midpoint heading), and so is their covariance
    (wheel_noise per root metre of each wheel, heading_noise per root metre of travel).
    A floor of a millimetre and a twentieth of a degree keeps an edge's covariance
    invertible when the robot stood still or only turned on the spot (the wheels'
    model then moves it only along its heading).

The casters (§3.2.1.5)
    Each rotation on the spot makes a casters' turn (pose_graph.CasterTurn) with the
    EKF's prior: a mean of caster_share of caster_worst in proportion to the rotation's
    net angle up to a quarter turn, the way it turned, and a spread of caster_sigma in
    proportion to the angle swept, plus what was still to come of the last one. Each
    step after it releases 1 - exp(-d / caster_settle) of what is left into the heading,
    as PoseFilter.predict does; an edge records how much of the turn it released, and
    the share the casters had turned its travel by on average. A turn settled to a
    thousandth is done. A keyframe is cut where the robot sets off, so that an edge
    releases one casters' turn only.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from giraff_console.robot.ekf import FilterNoise, Observation, usable
from giraff_console.robot.localisation import start_covariance
from giraff_console.robot.odometry import Pose
from giraff_console.robot.pose_graph import (
    CasterTurn,
    OdometryEdge,
    PosePrior,
    Sighting,
    Survey,
    Wall,
)

KEYFRAME_TRAVEL_M = 0.25
KEYFRAME_TURN = math.radians(10.0)
NEW_MARKER_TRAVEL_M = 0.05
NEW_MARKER_TURN = math.radians(3.0)
BLIND_TRAVEL_M = 1.0
BLIND_TURN = math.radians(45.0)
# Less than this since the last keyframe is standing still.
STILL_M = 0.002
STILL_TURN = math.radians(0.2)
EDGE_FLOOR_M = 0.001
EDGE_FLOOR_TURN = math.radians(0.05)
CASTERS_SETTLED = 1e-3


@dataclass
class _Pending:
    """The wheels since the last keyframe."""

    motion: np.ndarray = field(default_factory=lambda: np.zeros(3))
    covariance: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    travel: float = 0.0
    caster: int | None = None
    release: float = 0.0
    swayed: float = 0.0  # the casters' share reached, times the travel, summed

    def edge(self) -> OdometryEdge:
        floor = np.diag([EDGE_FLOOR_M**2, EDGE_FLOOR_M**2, EDGE_FLOOR_TURN**2])
        return OdometryEdge(
            Pose(*(float(v) for v in self.motion)), self.covariance + floor, self.caster,
            self.release, self.swayed / self.travel if self.travel > 0 else 0.0,
        )  # fmt: skip

    @property
    def turn(self) -> float:
        return abs(float(self.motion[2]))


class SurveyLog:
    """Keyframes, edges and sightings from a survey's wheels and frames (see the module
    docstring). No poses: the solver makes its own start (pose_graph_start.py)."""

    def __init__(self, start: Pose, wheel_base: float, *, noise: FilterNoise | None = None,
                 start_cov: np.ndarray | None = None,
                 camera_forward: float = 0.0) -> None:  # fmt: skip
        """`start`: the dock, known to `start_cov` (localisation.start_covariance's 5 cm
        and 3 degrees by default)."""
        if not wheel_base > 0:
            raise ValueError("the wheel base must be positive")
        self.start = PosePrior(start, start_covariance() if start_cov is None else start_cov)
        self.wheel_base = wheel_base
        self.noise = noise or FilterNoise()
        self.camera_forward = camera_forward
        self.edges: list[OdometryEdge] = []
        self.sightings: list[Sighting] = []
        self.caster_turns: list[CasterTurn] = []
        self._seen: list[set[int]] = [set()]
        self._pending = _Pending()
        # The rotation on the spot under way (net angle, swept), the casters' turn being
        # released and the share of it still to come.
        self._rotation: tuple[float, float] | None = None
        self._caster: int | None = None
        self._to_come = 0.0

    @property
    def keyframes(self) -> int:
        """Keyframes so far (the wheels since the last one will end in one more)."""
        return len(self._seen)

    def wheels(self, left_m: float, right_m: float, turned_in_place: bool = False) -> None:
        """The wheels' travel since the last poll (metres), as PoseFilter.predict takes it."""
        distance = (left_m + right_m) / 2
        turn = (right_m - left_m) / self.wheel_base
        if turned_in_place and turn != 0.0:
            angle, swept = self._rotation or (0.0, 0.0)
            self._rotation = angle + turn, swept + abs(turn)
        elif distance != 0.0 and self._rotation is not None:
            self._set_off()
        self._step(left_m, right_m, distance, turn)
        pending = self._pending
        if pending.travel >= BLIND_TRAVEL_M or pending.turn >= BLIND_TURN:
            self._cut()

    def frame(self, sightings: Iterable[Observation]) -> None:
        """One camera frame's markers, as seen from where the wheels last left the robot."""
        nearest: dict[int, Observation] = {}
        for o in sightings:
            checked = usable(o)
            if checked is None:
                continue
            before = nearest.get(checked.marker_id)
            if before is None or checked.distance_m < before.distance_m:
                nearest[checked.marker_id] = checked
        if not nearest:
            return
        pending = self._pending
        here = self._seen[-1]
        recent = here | (self._seen[-2] if len(self._seen) > 1 else set())
        due = pending.travel >= KEYFRAME_TRAVEL_M or pending.turn >= KEYFRAME_TURN
        new = bool(set(nearest) - recent) and (
            pending.travel >= NEW_MARKER_TRAVEL_M or pending.turn >= NEW_MARKER_TURN)  # fmt: skip
        if due or new:
            self._cut()
        elif not (pending.travel < STILL_M and pending.turn < STILL_TURN):
            return
        keyframe = len(self._seen) - 1
        for marker_id, o in sorted(nearest.items()):
            if marker_id not in self._seen[-1]:
                self._seen[-1].add(marker_id)
                self.sightings.append(Sighting(keyframe, o))

    def touched(self, extra: np.ndarray) -> None:
        """The robot stalled against something: what it was pushed or turned, which the
        wheels do not tell, as `extra` (a 3x3 covariance, Localisation.touched's) on the
        edge under way, carried through its steps after this as the wheels' own."""
        self._pending.covariance = self._pending.covariance + np.asarray(extra, dtype=float)

    def survey(self, known: Mapping[int, PosePrior] | None = None,
               walls: Mapping[int, Wall] | None = None) -> Survey:  # fmt: skip
        """The survey so far, the wheels since the last keyframe ending in one more."""
        edges = list(self.edges)
        pending = self._pending
        if pending.travel >= STILL_M or pending.turn >= STILL_TURN:
            edges.append(pending.edge())
        return Survey(start=self.start, odometry=edges, sightings=list(self.sightings),
                      caster_turns=list(self.caster_turns), known=dict(known or {}),
                      walls=dict(walls or {}), noise=self.noise,
                      camera_forward=self.camera_forward)  # fmt: skip

    def _step(self, left: float, right: float, distance: float, turn: float) -> None:
        """Integrate one step into the pending edge, as PoseFilter.predict does."""
        pending, noise = self._pending, self.noise
        if distance != 0.0 and self._caster is not None:
            released = self._to_come * -math.expm1(-abs(distance) / noise.caster_settle)
            pending.caster = self._caster
            pending.swayed += (pending.release + released / 2) * abs(distance)
            pending.release += released
            self._to_come -= released
            if self._to_come < CASTERS_SETTLED:
                self._caster = None
        x, y, heading = pending.motion
        mid = heading + turn / 2
        cos_mid, sin_mid = math.cos(mid), math.sin(mid)
        pending.motion = np.array([x + distance * cos_mid, y + distance * sin_mid, heading + turn])
        f = np.array([[1.0, 0.0, -distance * sin_mid], [0.0, 1.0, distance * cos_mid],
                      [0.0, 0.0, 1.0]])  # fmt: skip
        # By the left and right wheels' travel, as PoseFilter.predict's.
        half = distance / 2 / self.wheel_base
        cross_sin, cross_cos = half * sin_mid, half * cos_mid
        w = np.array([[cos_mid / 2 + cross_sin, cos_mid / 2 - cross_sin],
                      [sin_mid / 2 - cross_cos, sin_mid / 2 + cross_cos],
                      [-1.0 / self.wheel_base, 1.0 / self.wheel_base]])  # fmt: skip
        wheels = np.diag([noise.wheel_noise**2 * abs(left), noise.wheel_noise**2 * abs(right)])
        p = f @ pending.covariance @ f.T + w @ wheels @ w.T
        p[2, 2] += noise.heading_noise**2 * abs(distance)
        pending.covariance = (p + p.T) / 2
        pending.travel += abs(distance)

    def _set_off(self) -> None:
        """The robot sets off after a rotation on the spot: its casters' turn begins."""
        assert self._rotation is not None
        angle, swept = self._rotation
        self._rotation = None
        noise = self.noise
        swung = min(1.0, abs(angle) / (math.pi / 2))
        sigma = noise.caster_sigma * min(1.0, swept / (math.pi / 2))
        if sigma > 0:
            carried = self._to_come if self._caster is not None else 0.0
            expected = math.copysign(noise.caster_share * noise.caster_worst * swung, angle)
            self.caster_turns.append(CasterTurn(expected, sigma, carried))
            self._caster, self._to_come = len(self.caster_turns) - 1, 1.0
        self._cut()

    def _cut(self) -> None:
        """A keyframe here: the pending wheels become an edge to it."""
        self.edges.append(self._pending.edge())
        self._seen.append(set())
        self._pending = _Pending()
