"""Where in each frame the marker eye looks for markers, and whether it looks at all
(issue 25).

Drawing the whole of every frame and looking through all of it was nine tenths of
what a simulated run cost (issue 25), and most frames hold one marker or none. The eye
knows, without any help from the camera, where the markers it is after should be:

- Tracking: a marker found in the last frame is looked for round where it was, moved
  by what the odometry says the robot did since (over a tenth of a second the
  odometry is good to millimetres, so this holds even while the estimate is off).
- Predicting: each of the plan's markers that the estimate, give or take three of its
  standard deviations, puts in view, facing the camera, large enough for the detector
  and not behind one of the plan's walls (when the eye knows them: `Building`), is
  looked for where it would be: in the box its square would fill when the camera's
  height and the markers' are known, else in the band of columns, the whole height of
  the frame.
- Searching: the whole frame, once every SEARCH_EVERY_S seconds, sooner once the robot
  has turned SEARCH_TURN_RAD since (a turn sweeps new walls into view, and a marker
  may be in view for only a few frames of it), and every frame while the robot is
  lost, so that a marker neither predicted nor tracked (moved on the wall, or the
  estimate wrong) is still found within that time of coming into view.
  A marker predicted but not found (too far or too askew to make out, or hidden by
  something the plan does not know) is left to that search too, rather than looked
  for again in every frame, unless it comes to look larger.

A frame with nothing to look for and no search due is not taken at all. Each region
reaches a margin beyond its marker's square (`margin`), where the detector finds the
marker exactly as in the whole frame (camera/markers.py, `MarkerDetector._find_in`).
None of it needs the simulator: it works as well for a real camera.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from giraff_console.camera.markers import (
    CameraIntrinsics,
    MarkerDetector,
    MarkerSighting,
    Region,
)
from giraff_console.robot.ekf import wrap
from giraff_console.robot.localisation import Estimate, Localisation
from giraff_console.robot.odometry import Pose

# The whole frame is searched once a second at least: a marker neither predicted nor
# tracked is found within that of coming into view.
SEARCH_EVERY_S = 1.0
# ... and sooner once the robot has turned this far since: a turn brings walls into
# view that the last search never saw.
SEARCH_TURN_RAD = math.radians(10.0)
# How many standard deviations of the estimate a prediction allows for.
SIGMAS = 3.0
# How far a tracked marker may have turned in the picture beyond what the odometry
# says, radians: the odometry's error over a frame, and the casters' sudden turn.
TRACK_SLACK_RAD = math.radians(2.0)
# A marker whose outline would be shorter than this share of the detector's least is
# not predicted: the estimate's distance may be a little off, so some slack.
SMALLEST_SHARE = 0.9
# A marker predicted but not found is looked for again before the next whole search
# once its outline would be this many times what it was when it was missed: a marker
# too far or too askew to make out becomes one that can be over some 15 % more pixels
# (a 16 cm marker is first made out about 6 m off, and the robot covers a metre in
# two or three seconds). Less looks again more often for few more sightings.
GROWN = 1.15
# Past this share of the frame, the regions are searched as the whole frame.
MOST_OF_THE_FRAME = 0.5
# Nearer the camera's plane than this a marker's edge is taken as beside the camera.
NEAR_M = 0.05
# A wall hides a marker only if it crosses the sight line this far short of the marker
# and this far from its own ends (more the estimate's spread): see `_behind_walls`.
WALL_CLEARANCE_M = 0.25
# Where across a marker's square its sight lines run, in sides: its middle and sides.
SIGHT_SAMPLES = (-0.5, 0.0, 0.5)


def margin(side_px: float) -> int:
    """Pixels a region reaches beyond a marker's square `side_px` across: the paper round
    the square (its quiet zone, a quarter of the side for the plan's pages, given half),
    and the 16 pixels the detector's thresholding needs beyond it to see the page as
    the whole frame shows it (its largest window is 23 pixels)."""
    return math.ceil(0.5 * side_px) + 16


@dataclass(frozen=True)
class Building:
    """What the eye knows of the building besides where the plan's markers are.

    `camera_height_m` and `marker_heights` (by id): how high the camera's lens and the
    markers' centres are above the floor, metres, with which a marker is predicted up
    and down as well as across. `walls`: the plan's walls, (x, y) to (x, y) a row,
    behind which a marker is not predicted."""

    camera_height_m: float | None = None
    marker_heights: Mapping[int, float] = field(default_factory=dict)
    walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))


@dataclass(frozen=True)
class Track:
    """A marker found in the last frame: its square's corners, where it was from the
    robot, and the odometry's pose when the frame was taken."""

    id: int
    corners: np.ndarray
    distance_m: float
    bearing_rad: float
    facing_rad: float
    odometry: Pose


class MarkerSearch:
    """Chooses, frame by frame, where the eye looks; see the module docstring.

    `localisation` gives the estimate and the plan's markers (their centres and the way
    they face); `detector` the markers' size, the camera's intrinsics and mount, and the
    smallest outline it finds; `building`, what else the eye knows of the building;
    `search_every`, how many frames apart the whole frame is searched."""

    def __init__(self, localisation: Localisation, detector: MarkerDetector,
                 building: Building | None = None, search_every: int = 10) -> None:  # fmt: skip
        if search_every < 1:
            raise ValueError("the whole frame must be searched every frame or more")
        self.localisation = localisation
        self.detector = detector
        self.building = building or Building()
        # The box round each wall, to pass over those far from a sight line quickly.
        self._wall_low = self.building.walls.min(axis=1)
        self._wall_high = self.building.walls.max(axis=1)
        self.search_every = search_every
        # Frames since the whole frame was last searched, and the odometry's heading
        # then: the first frame is searched whole.
        self._since = search_every
        self._searched_at = math.nan
        self._tracks: list[Track] = []
        self._odometry = Pose(0.0, 0.0, 0.0)
        self._plan: tuple[Mapping[int, Pose], np.ndarray] | None = None
        # The markers predicted in the frame being looked at, and those predicted since
        # the last whole search but not found, with the outline each was predicted to
        # have then (pixels): left to the next search unless they grow.
        self._asked: dict[int, float] = {}
        self._whole = False
        self._missed: dict[int, float] = {}

    def regions(self, width: int, height: int) -> list[Region] | None:
        """Where to look in the frame about to be taken: None for all of it, an empty
        list for nowhere (the frame need not be taken)."""
        estimate = self.localisation.estimate()
        self._odometry = estimate.odometry
        self._asked = {}
        self._since += 1
        # Due after SEARCH_EVERY_S, or sooner once the robot has turned to a new view.
        turned = abs(wrap(estimate.odometry.heading - self._searched_at)) > SEARCH_TURN_RAD
        due = self._since >= self.search_every or turned
        intrinsics = self.detector.intrinsics(width, height)
        # Prediction assumes a level camera (the simulator's, and the Giraff's unless
        # told otherwise); without intrinsics nothing can be placed in the picture.
        self._whole = estimate.lost or intrinsics is None or bool(self.detector.mount.pitch)
        if not self._whole and intrinsics is not None:
            predicted = self._predicted(estimate, intrinsics, width, height)
            regions = None if due else self._looking(predicted, estimate, intrinsics, width,
                                                     height)  # fmt: skip
            if regions is not None:
                return regions
            self._asked = {seen.id: seen.outline_px for seen in predicted}
        self._whole = True
        self._since = 0
        self._searched_at = estimate.odometry.heading
        return None

    def _looking(
        self, predicted: list[Predicted], estimate: Estimate, intrinsics: CameraIntrinsics,
        width: int, height: int,
    ) -> list[Region] | None:  # fmt: skip
        """The regions round the markers tracked, and round those predicted that are
        neither tracked nor left to the next search; None if they would cover most of
        the frame."""
        fx, cx = intrinsics.fx, intrinsics.cx
        regions = [self._tracked(track, fx, cx, intrinsics.cy, height) for track in self._tracks]
        tracked = {track.id for track in self._tracks}
        spread = SIGMAS * estimate.sigma_heading
        for seen in predicted:
            # A marker predicted but not found is left to the next whole search, unless
            # it comes to look larger: one too far or too askew to make out is not
            # looked for in every frame.
            missed = self._missed.get(seen.id)
            if seen.id in tracked or (missed is not None and seen.outline_px < GROWN * missed):
                continue
            self._asked[seen.id] = seen.outline_px
            reach = margin(seen.side_px)
            left = _column(seen.high + spread, fx, cx) - reach
            right = _column(seen.low - spread, fx, cx) + reach
            regions.append(
                Region(
                    math.floor(left),
                    math.floor(seen.top) - reach,
                    math.ceil(right) + 1,
                    math.ceil(seen.bottom) + 1 + reach,
                )
            )
        regions = _joined([r for r in (r.within(width, height) for r in regions) if r.area])
        if sum(region.area for region in regions) > MOST_OF_THE_FRAME * width * height:
            return None
        return regions

    def seen(self, sightings: list[MarkerSighting]) -> None:
        """The markers found in the frame just taken: tracked into the next."""
        found = {s.id for s in sightings}
        missed = {i: outline for i, outline in self._asked.items() if i not in found}
        self._missed = missed if self._whole else self._missed | missed
        self._tracks = [
            Track(s.id, s.corners, s.distance_m, s.bearing_rad, s.facing_rad, self._odometry)
            for s in sightings
            if math.isfinite(s.distance_m) and math.isfinite(s.facing_rad)
        ]

    def _tracked(self, track: Track, fx: float, cx: float, cy: float, height: int) -> Region:
        """Where a tracked marker's square will be: its columns from where the odometry
        moved the robot to since, its rows those it had, grown or shrunk about the
        horizon as the marker came nearer or went away."""
        moved = _between(track.odometry, self._odometry)
        x, y = _moved(track.distance_m * math.cos(track.bearing_rad),
                      track.distance_m * math.sin(track.bearing_rad), moved)  # fmt: skip
        facing = track.facing_rad - moved.heading
        half = self.detector.size / 2
        across = np.array([-math.sin(facing), math.cos(facing)]) * half
        centre = np.array([x, y])
        edges = np.array([centre + across, centre - across])
        forward = self.detector.mount.forward
        before = track.distance_m * math.cos(track.bearing_rad) - forward
        now = x - forward
        top, bottom = track.corners[:, 1].min(), track.corners[:, 1].max()
        left, right = track.corners[:, 0].min(), track.corners[:, 0].max()
        side = max(bottom - top, right - left)
        if now > NEAR_M and before > NEAR_M and (edges[:, 0] - forward > NEAR_M).all():
            angles = np.arctan2(edges[:, 1], edges[:, 0] - forward)
            left = min(left, _column(angles.max() + TRACK_SLACK_RAD, fx, cx))
            right = max(right, _column(angles.min() - TRACK_SLACK_RAD, fx, cx))
            scale = before / now
            top = min(top, cy + (top - cy) * scale)
            bottom = max(bottom, cy + (bottom - cy) * scale)
            side *= max(scale, 1.0)
        else:  # at the picture's edge: it may be anywhere up or down
            top, bottom = 0, height
        reach = margin(side)
        return Region(math.floor(left) - reach, math.floor(top) - reach,
                      math.ceil(right) + 1 + reach, math.ceil(bottom) + 1 + reach)  # fmt: skip

    def _predicted(self, estimate: Estimate, intrinsics: CameraIntrinsics, width: int,
                   height: int) -> list[Predicted]:  # fmt: skip
        """The plan's markers the estimate, give or take its spread, puts wholly in view:
        the detector finds a marker only whole, so one that cannot be wholly in the
        frame is not looked for."""
        pose, sigma_m = estimate.pose, estimate.sigma_m
        fx, fy, cx, cy = intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy
        cos, sin = math.cos(pose.heading), math.sin(pose.heading)
        forward = self.detector.mount.forward
        table = self._plan_table()
        rel_x = table[:, 1] - (pose.x + forward * cos)
        rel_y = table[:, 2] - (pose.y + forward * sin)
        reach = np.hypot(rel_x, rel_y)
        # None farther than this has the outline the detector needs, even face on at the
        # edge of the view (where it is nearest the camera's plane for its distance):
        # the rest of the work is for the few nearer.
        smallest = SMALLEST_SHARE * self.detector.smallest_perimeter(width, height)
        deepest = 4 * fy * self.detector.size / smallest
        slack = self.detector.size + SIGMAS * sigma_m
        near = reach <= deepest * math.hypot(fx, cx + 0.5) / fx + slack
        ids, mx, my, facing, centre = table[near].T
        rel_x, rel_y, reach = rel_x[near], rel_y[near], reach[near]
        if not len(ids):
            return []
        # Faces the camera: its normal points back towards it.
        towards = -(np.cos(facing) * rel_x + np.sin(facing) * rel_y) > 0
        # The square's two sides, ahead of the camera and to its left.
        half = self.detector.size / 2
        sides = []
        for sign in (1.0, -1.0):
            ex = rel_x - sign * np.sin(facing) * half
            ey = rel_y + sign * np.cos(facing) * half
            sides.append((cos * ex + sin * ey, -sin * ex + cos * ey))
        farthest = np.maximum(sides[0][0], sides[1][0])
        nearest = np.maximum(np.minimum(sides[0][0], sides[1][0]), NEAR_M)
        angles = np.stack([np.arctan2(left, np.maximum(ahead, NEAR_M)) for ahead, left in sides])
        spread = SIGMAS * sigma_m / np.maximum(reach, NEAR_M)
        low, high = angles.min(axis=0) - spread, angles.max(axis=0) + spread
        # Turned by up to the spread of the estimate's position and heading, it could
        # stand wholly within the picture's edges.
        turn = spread + SIGMAS * estimate.sigma_heading
        half_view = math.atan2(cx + 0.5, fx)
        whole = (high - spread - turn <= half_view) & (low + spread + turn >= -half_view)
        # The outline it would have at most: its height, and its width across.
        tall = fy * self.detector.size / nearest
        wide = np.abs(fx * np.diff(np.tan(np.clip(angles, -1.5, 1.5)), axis=0)[0])
        outline = 2 * (tall + np.minimum(wide, tall))
        visible = towards & (farthest > NEAR_M) & (outline >= smallest) & whole
        visible[visible] = ~self._behind_walls(
            pose, forward, mx[visible], my[visible], facing[visible], sigma_m
        )
        # Its rows, between the nearest and the farthest it may be: all where the
        # heights are unknown.
        near = nearest - SIGMAS * sigma_m
        far = np.maximum(farthest, NEAR_M) + SIGMAS * sigma_m
        top, bottom = np.zeros(len(ids)), np.full(len(ids), float(height))
        camera_height = self.building.camera_height_m
        if camera_height is not None:
            near = np.maximum(near, NEAR_M)
            above = centre + half - camera_height  # the square's top above the lens
            below = centre - half - camera_height
            known = np.isfinite(centre)
            top = np.where(known, cy - fy * np.maximum(above / near, above / far), top)
            bottom = np.where(known, cy - fy * np.minimum(below / near, below / far), bottom)
        return [Predicted(int(ids[i]), float(low[i]), float(high[i]), float(tall[i]),
                          float(top[i]), float(bottom[i]), float(outline[i]))
                for i in np.flatnonzero(visible)]  # fmt: skip

    def _plan_table(self) -> np.ndarray:
        """The plan's markers, a row each: id, centre x and y, the way it faces, and its
        centre's height (NaN if unknown); made again when the plan's markers change."""
        markers = self.localisation.markers
        if self._plan is None or self._plan[0] is not markers:
            heights = self.building.marker_heights
            table = np.array([(i, p.x, p.y, p.heading, heights.get(i, math.nan))
                              for i, p in markers.items()], dtype=float).reshape(-1, 5)  # fmt: skip
            self._plan = (markers, table)
        return self._plan[1]

    def _behind_walls(self, pose: Pose, forward: float, mx: np.ndarray, my: np.ndarray,
                      facing: np.ndarray, sigma_m: float) -> np.ndarray:  # fmt: skip
        """Which of these markers the plan's walls hide from the camera: the sight lines
        to the middle of each one's square and to both its sides all cross a wall.

        Only a clear crossing counts, so that a plan a few centimetres out, or an
        estimate a few standard deviations off, never hides a marker in view: a wall
        must cross a sight line WALL_CLEARANCE_M short of the marker, and away from the
        camera and from the wall's own ends by that and the estimate's spread (the
        robot may stand on the far side of a wall it is believed to be beside)."""
        walls = self.building.walls
        if not len(walls) or not len(mx):
            return np.zeros(len(mx), dtype=bool)
        camera = np.array([pose.x + forward * math.cos(pose.heading),
                           pose.y + forward * math.sin(pose.heading)])  # fmt: skip
        across = np.array(SIGHT_SAMPLES)[None, :] * self.detector.size
        points = np.stack([mx[:, None] - np.sin(facing)[:, None] * across,
                           my[:, None] + np.cos(facing)[:, None] * across], axis=-1)  # fmt: skip
        sight = (points - camera).reshape(-1, 2)  # (sight lines, 2)
        # Only walls that reach into the box round the sight lines can cross them.
        low = np.minimum(points.reshape(-1, 2).min(axis=0), camera)
        high = np.maximum(points.reshape(-1, 2).max(axis=0), camera)
        reaching = (self._wall_high >= low) & (self._wall_low <= high)
        walls = walls[reaching[:, 0] & reaching[:, 1]]
        starts, ends = walls[:, 0], walls[:, 1]
        edge = ends - starts
        length = np.hypot(edge[:, 0], edge[:, 1])
        rx, ry = (starts - camera).T
        ex, ey = edge.T
        sx, sy = sight[:, 0, None], sight[:, 1, None]
        denominator = sx * ey - sy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            # Where along the sight line (0 at the camera, 1 at the marker) and along the
            # wall (0 to 1) the two cross.
            t = (rx * ey - ry * ex) / denominator
            u = (rx * sy - ry * sx) / denominator
        reach = np.hypot(sight[:, 0], sight[:, 1])[:, None]
        clear = WALL_CLEARANCE_M + SIGMAS * sigma_m
        crosses = (t * reach > clear) & (t * reach < reach - WALL_CLEARANCE_M)
        crosses &= (u * length > clear) & ((1 - u) * length > clear)
        return crosses.any(axis=1).reshape(points.shape[:2]).all(axis=1)


@dataclass(frozen=True)
class Predicted:
    """One of the plan's markers the estimate puts in view: the directions of its
    square's two sides from the camera (radians, left positive) widened by the estimate's
    position spread, its side in pixels, the rows it fills (all, if unknown), and the
    outline it would have at most, pixels."""

    id: int
    low: float
    high: float
    side_px: float
    top: float
    bottom: float
    outline_px: float


def _column(angle: float, fx: float, cx: float) -> float:
    """The picture's column (pixels) in the direction `angle` (radians, left positive)
    from a level camera's axis, clipped short of straight aside."""
    return cx - fx * math.tan(min(max(angle, -1.5), 1.5))


def _between(a: Pose, b: Pose) -> Pose:
    """`b` in `a`'s frame: the move from a to b as the robot at a sees it."""
    dx, dy = b.x - a.x, b.y - a.y
    cos_a, sin_a = math.cos(a.heading), math.sin(a.heading)
    return Pose(cos_a * dx + sin_a * dy, -sin_a * dx + cos_a * dy, b.heading - a.heading)


def _moved(x: float, y: float, move: Pose) -> tuple[float, float]:
    """A point in the robot's frame, as seen after the robot made `move`."""
    x, y = x - move.x, y - move.y
    cos_t, sin_t = math.cos(move.heading), math.sin(move.heading)
    return cos_t * x + sin_t * y, -sin_t * x + cos_t * y


def _joined(regions: list[Region]) -> list[Region]:
    """`regions`, those that overlap replaced by the region round both, until none do:
    each pixel is looked at once, and a marker is never cut in two."""
    regions = list(regions)
    i = 0
    while i < len(regions):
        for j in range(i + 1, len(regions)):
            if regions[i].overlaps(regions[j]):
                regions[i] = regions[i].around(regions.pop(j))
                i = -1  # a grown region may now overlap an earlier one
                break
        i += 1
    return regions
