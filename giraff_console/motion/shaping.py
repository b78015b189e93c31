"""Path shaping: a planned polyline made into lines, clothoid turns and turns on the spot.

The thesis found only two ways to end a curve on the board, a full stop or forcing
`vgr` to zero, "which causes a noticeable jerk", and hoped that "some future autonomous
navigation solution ... might be able to plan its moves in such a way that it could
avoid this issue" (§3.2.1.4, §5.4). The board ramps its gear ratio linearly with
distance (A.2.3), so the curves it can drive without a jump are clothoids; a turn here
is a clothoid in (the ratio ramping up at the turn's sharpness), an arc where the ratio
would pass its limit, and a clothoid out (ramping back to zero), symmetric about the
corner it replaces. Such a turn leaves the straight line before the corner and rejoins
the next one after it, at its tangent length T from the corner.

Each corner gets the smoothest turn (the lowest sharpness) that fits: its tangent
length within the half of each adjoining leg it may use, and its way round the corner,
which cuts inside it, clear of obstacles on the grid. Where no turn fits, the robot
stops and turns on the spot: at the start and the end when its heading must change,
and at a corner too sharp or too cramped for a curve, such as some doorway approaches.
Turning on the spot costs time, and a real Giraff's casters then pull it off line as
it sets off again (§3.2.1.5), so it is the last resort.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import pairwise

from giraff_console.motion.path import Drive, Rotation, Section, Segment, wrap
from giraff_console.protocol.kinematics import TURN_RADIUS_M
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]
# Whether the straight line between two points is clear of obstacles (the planner's grid).
ClearLine = Callable[[Point, Point], bool]

# Headings closer than this are taken as equal: the executor's steering takes up the rest.
ALIGNED_RAD = math.radians(1.0)
# Corners sharper than this are turned on the spot: a curve round them would be huge.
MAX_CURVE_TURN_RAD = math.radians(150.0)
# Points closer than this are one point.
MIN_LEG_M = 0.01
# Corners that turn less than this are dropped: the heading it leaves out is too small
# to matter, and a clothoid for it would be a few millimetres long.
STRAIGHT_RAD = 1e-4
# The turn's shape is checked for obstacles every this many metres.
CLEARANCE_STEP_M = 0.05


@dataclass(frozen=True)
class TurnLimits:
    """How sharp a turn may be. The gear ratio must stay below 0.51 (§3.2.1.4) with
    room for steering corrections; the sharpness is the ratio's ramp `vgr` per metre
    (teleop ramps at 1.0, the thesis's DEF_VGACCEL)."""

    max_gear: float = 0.45
    min_sharpness: float = 0.5  # 1/m^2: the smoothest turn tried
    max_sharpness: float = 1.0 / TURN_RADIUS_M  # a ramp of 1.0 gear ratio per metre
    steps: int = 12  # sharpnesses tried between the two, geometrically spaced

    @property
    def max_curvature(self) -> float:
        return self.max_gear / TURN_RADIUS_M

    def sharpnesses(self) -> list[float]:
        ratio = self.max_sharpness / self.min_sharpness
        return [self.min_sharpness * ratio ** (i / (self.steps - 1)) for i in range(self.steps)]


def shape(points: Sequence[Point], heading: float, goal_heading: float | None = None,
          clear: ClearLine | None = None, limits: TurnLimits = TurnLimits(),
          pins: frozenset[Point] = frozenset()) -> tuple[Section, ...]:  # fmt: skip
    """The sections that drive along `points` from a robot at points[0] facing `heading`,
    ending at points[-1], facing `goal_heading` if given.

    `pins` are points driven straight through, such as doorways: no turn reaches past
    them, so the turns on either side keep to their own side of the door."""
    corners = _simplified(points, pins)
    sections: list[Section] = []
    here = Pose(corners[0][0], corners[0][1], heading)
    if len(corners) == 1:
        if goal_heading is not None and abs(wrap(goal_heading - heading)) > ALIGNED_RAD:
            sections.append(Rotation(here, wrap(goal_heading - heading)))
        return tuple(sections)
    directions = [math.atan2(b[1] - a[1], b[0] - a[0]) for a, b in pairwise(corners)]
    lengths = [math.dist(a, b) for a, b in pairwise(corners)]
    segments: list[Segment] = []

    def rotate_to(direction: float) -> None:
        nonlocal here, segments
        angle = wrap(direction - here.heading)
        if abs(angle) <= ALIGNED_RAD:
            here = Pose(here.x, here.y, direction)
            return
        if segments:
            sections.append(Drive(tuple(segments)))
            segments = []
        sections.append(Rotation(here, angle))
        here = Pose(here.x, here.y, direction)

    # The tangent each corner needs at the least: its sharpest turn (0 on the spot).
    needs = [0.0] * len(corners)
    for i in range(1, len(corners) - 1):
        deflection = wrap(directions[i] - directions[i - 1])
        if STRAIGHT_RAD < abs(deflection) <= MAX_CURVE_TURN_RAD:
            needs[i] = turn_shape(deflection, limits.max_sharpness, limits.max_curvature)[0]
    rotate_to(directions[0])
    # How much of each leg is left for the turn at its far end.
    free_before = lengths[0]
    for i in range(1, len(corners) - 1):
        deflection = wrap(directions[i] - directions[i - 1])
        if corners[i] in pins and abs(deflection) <= STRAIGHT_RAD:
            here = _line_to(segments, here, corners[i])
            free_before = lengths[i]
            continue
        last = i + 1 == len(corners) - 1 or corners[i + 1] in pins
        # The leg after is shared with the next corner: this one may take what that one
        # needs at the least, or half, whichever leaves this one more.
        room_after = lengths[i] if last else max(lengths[i] / 2, lengths[i] - needs[i + 1])
        turn = None
        if abs(deflection) <= MAX_CURVE_TURN_RAD:
            turn = _fitting_turn(corners[i], directions[i - 1], deflection,
                                 min(free_before, room_after), clear, limits)  # fmt: skip
        if turn is None:
            # No curve fits: drive to the corner, stop and turn there.
            here = _line_to(segments, here, corners[i])
            rotate_to(directions[i])
            free_before = lengths[i]
            continue
        tangent, pieces = turn
        start = _along(corners[i], directions[i - 1], -tangent)
        here = _line_to(segments, here, start)
        for length, k0, k1 in pieces:
            segment = Segment(here, length, k0, k1)
            segments.append(segment)
            here = segment.end
        here = Pose(here.x, here.y, directions[i])
        free_before = lengths[i] - tangent
    here = _line_to(segments, here, corners[-1])
    if goal_heading is not None:
        rotate_to(goal_heading)
    if segments:
        sections.append(Drive(tuple(segments)))
    return tuple(sections)


def turn_shape(deflection: float, sharpness: float,
               max_curvature: float) -> tuple[float, list[tuple[float, float, float]]]:  # fmt: skip
    """The symmetric turn through `deflection` (positive left): its tangent length, and
    its pieces as (length, k0, k1): clothoid in, the arc if the peak curvature is
    reached, clothoid out."""
    sign = 1.0 if deflection > 0 else -1.0
    angle = abs(deflection)
    if angle <= max_curvature**2 / sharpness:
        peak = math.sqrt(angle * sharpness)
        arc = 0.0
    else:
        peak = max_curvature
        arc = (angle - peak**2 / sharpness) / peak
    ramp = peak / sharpness
    pieces = [(ramp, 0.0, sign * peak)]
    if arc > 0:
        pieces.append((arc, sign * peak, sign * peak))
    pieces.append((ramp, sign * peak, 0.0))
    # Drive the turn from the origin along +x; the corner is where the lines meet.
    here = Pose()
    for length, k0, k1 in pieces:
        here = Segment(here, length, k0, k1).end
    tangent = here.x - here.y * math.cos(angle) / math.sin(angle) * sign
    return tangent, pieces


Pieces = list[tuple[float, float, float]]  # (length, k0, k1) of each piece of a turn


def _fitting_turn(
    corner: Point,
    direction: float,
    deflection: float,
    room: float,
    clear: ClearLine | None,
    limits: TurnLimits,
) -> tuple[float, Pieces] | None:
    """The smoothest turn at `corner` whose tangent fits in `room` and whose way round
    the corner is clear; None if none is."""
    for sharpness in limits.sharpnesses():
        tangent, pieces = turn_shape(deflection, sharpness, limits.max_curvature)
        if tangent > room:
            continue
        if clear is None or _turn_is_clear(corner, direction, tangent, pieces, clear):
            return tangent, pieces
    return None


def _turn_is_clear(corner: Point, direction: float, tangent: float,
                   pieces: list[tuple[float, float, float]], clear: ClearLine) -> bool:  # fmt: skip
    start = _along(corner, direction, -tangent)
    here = Pose(start[0], start[1], direction)
    points = [start]
    for length, k0, k1 in pieces:
        segment = Segment(here, length, k0, k1)
        steps = max(1, math.ceil(length / CLEARANCE_STEP_M))
        for j in range(1, steps + 1):
            pose = segment.pose_at(length * j / steps)
            points.append((pose.x, pose.y))
        here = segment.end
    return all(clear(a, b) for a, b in pairwise(points))


def _simplified(points: Sequence[Point], pins: frozenset[Point]) -> list[Point]:
    """The points without repeats and without corners that do not turn, pins kept."""
    kept: list[Point] = [points[0]]
    for point in points[1:]:
        if math.dist(point, kept[-1]) >= MIN_LEG_M:
            kept.append(point)
    if kept[-1] != points[-1]:
        # The goal is kept, in place of a point close to it (or after the start).
        if len(kept) > 1:
            kept[-1] = points[-1]
        elif math.dist(points[-1], kept[0]) > 0:
            kept.append(points[-1])
    if len(kept) == 1:
        return kept
    straightened = [kept[0]]
    for point, after in pairwise(kept[1:]):
        before = straightened[-1]
        turn = wrap(math.atan2(after[1] - point[1], after[0] - point[0])
                    - math.atan2(point[1] - before[1], point[0] - before[0]))  # fmt: skip
        if abs(turn) > STRAIGHT_RAD or point in pins:
            straightened.append(point)
    straightened.append(kept[-1])
    return straightened


def _along(point: Point, direction: float, distance: float) -> Point:
    return point[0] + distance * math.cos(direction), point[1] + distance * math.sin(direction)


def _line_to(segments: list[Segment], here: Pose, target: Point) -> Pose:
    """A straight segment from `here` to `target` (if they are apart); the pose there."""
    length = math.dist((here.x, here.y), target)
    if length < 1e-9:
        return here
    direction = math.atan2(target[1] - here.y, target[0] - here.x)
    segment = Segment(Pose(here.x, here.y, direction), length)
    segments.append(segment)
    return segment.end
