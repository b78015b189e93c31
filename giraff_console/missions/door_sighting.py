"""Where a doorway's opening is, as the range sensor sees it (issue 29).

A plan taught by driving (planning/map_building.py) draws each door from the map's 5 cm
cells and its local error: in the taught home (bench/teach_building.py) the truth's
0.8 m doors came out 0.70 to 0.80 m wide, their middles up to 7.5 cm along their walls
from the real ones, and a 0.9 m door's 15 cm. A 0.6 m robot has 10 cm a side in a 0.8 m
door: crossing at the map's middle it passed 2.5 cm from a real jamb, and with the
pose's few centimetres touched it three times and ended a patrol (docs/performance.md).

The lidar sees the jambs themselves, and in the frame the robot steers by, so a pose a
few centimetres off moves them with the robot. Of a revolution's hits on the doorway's
wall (within WALL_BAND_M of its line, JAMB_SEARCH_M past the plan's jambs), those at the
wall's face (JAMB_DEPTH_M of their median across the wall: not something standing in
front of it) nearest the plan's middle on either side are the opening's ends. Every hit
on a wall lies at or beyond its jamb, so a sparse revolution sees the opening wider by up
to a beam's spacing at either end, more on the side it sees at a glancing angle: the
middle is the median of MIN_SIGHTINGS revolutions in a row, from within SIGHT_M, that
agree within AGREE_M. The route planner crosses the doorway there from then on, as near
as the plan's walls leave clear (planning/route_planner.py).

A taught map draws a door narrower than it is, or wider: 1.10 m for a real 0.80. A real
jamb then stands up to 0.3 m inside the plan's doorway, beyond KNOWN_WALL_M of the
plan's wall, where the lookout takes it for something in the way (missions/lookout.py);
a crossing at the plan's middle meets it, and patrols planned new ways round something
at that door until they gave up (docs/performance.md). So an opening seen is taken at
any width that leaves the robot SIDE_M a side. Something standing at a doorway's side (a
person, a door's leaf, a walker) at the wall's face narrows it the same way: the middle
seen is then the middle of what is left, part of the real opening, and crossing there
the robot keeps clear of the real jambs and of the thing, whether it stays or goes. A
revolution says nothing of a doorway whose opening it does not show both ends of, or
shows narrower than that (nothing passes) or much wider than the plan's, or with its
middle more than MAX_SHIFT_M from the plan's (it has seen something else); nor does one
taken while the robot turned, or moved along the doorway's wall by more than SMEAR_M:
its beams, each taken at its own moment of the turn, are placed from the pose half way
through it (missions/lookout.py), and the jambs' by up to half that motion off.
"""

from __future__ import annotations

import collections
import math
import statistics
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from giraff_console.planning.floorplan import Door, Point

# From further than this the beams (1 degree apart on an RPLIDAR A1) are 3.5 cm apart
# on the jambs, and a heading a degree off moves a door as much: too coarse to place a
# middle that has 10 cm a side.
SIGHT_M = 2.0
# Hits this far either side of the door's line are on its wall: a taught wall's line is
# up to 10 cm off the real one, and a wall is 0.1 to 0.2 m thick.
WALL_BAND_M = 0.25
# An end of the opening is a hit this near the wall's face, across the wall: a jamb's
# face runs through the wall's thickness; a chair or a person in front of it does not.
JAMB_DEPTH_M = 0.15
# The opening's ends are looked for this far beyond the plan's jambs.
JAMB_SEARCH_M = 0.25
# An opening seen to leave the robot less than this a side is no way through. A sparse
# revolution sees it up to a beam's spacing wider at each end (3.5 cm from SIGHT_M), so
# one taken leaves the robot 4 cm a side at least; a real 0.8 m door (0.1 m a side for
# a 0.6 m robot) is seen 0.75 m wide or wider, on the simulator's 5 cm cells too.
SIDE_M = 0.075
# A middle further than this from the plan's is not this doorway's (the taught home's
# worst was 15 cm).
MAX_SHIFT_M = 0.2
# A revolution during which the robot moved further than this along the doorway's wall
# places its jambs up to half as far off.
SMEAR_M = 0.02
# A doorway's middle is the median of this many sightings in a row that agree within
# AGREE_M: one revolution's jamb can be a beam's spacing off; and a heading a degree off
# turns the scene round the robot, a door 2 m away by 3.5 cm. A constant error moves the
# robot's own driving with it, but one being corrected (a fix after the casters turned
# it, §3.2.1.5) moves the door from one revolution to the next: seen leaving a room after
# a turn on the spot, a door's middle went -7, -11, -14 cm in three revolutions, where it
# is +5 (and a patrol touched its jamb three times).
MIN_SIGHTINGS = 3
AGREE_M = 0.03
# A median that moves less than this has not moved: the planner's crossings are tried
# a centimetre apart (route_planner.py's SHIFT_STEP_M).
MOVED_M = 0.005


@dataclass(frozen=True)
class Doorway:
    """A door of the plan as a sighting needs it: where, and which way its wall runs."""

    door: Door
    along: Point  # a unit vector along its wall

    @classmethod
    def in_wall(cls, door: Door, a: Point, b: Point) -> Doorway:
        """`door`, in the wall through `a` and `b` (two distinct points)."""
        length = math.dist(a, b)
        return cls(door, ((b[0] - a[0]) / length, (b[1] - a[1]) / length))

    def middle_at(self, offset: float) -> Point:
        """The point `offset` metres along the wall from the plan's middle."""
        (x, y), (ux, uy) = self.door.at, self.along
        return (x + ux * offset, y + uy * offset)


@dataclass(frozen=True)
class Revolution:
    """One revolution's hits (an N x 2 array, map frame), where it was taken from, and
    how the robot moved while it was taken (metres, map frame; turned: faster than the
    lidar's revolutions can be placed)."""

    hits: np.ndarray
    seen_from: Point
    taken_at: float
    moved: Point = (0.0, 0.0)
    turned: bool = False


def opening_middle(doorway: Doorway, hits: np.ndarray, robot_width: float) -> float | None:
    """The middle of the doorway's opening as `hits` (an N x 2 array, map frame) show
    it, in metres along its wall from the plan's middle; None when they do not show it
    (module docstring)."""
    door = doorway.door
    if not len(hits):
        return None
    (x, y), (ux, uy) = door.at, doorway.along
    dx, dy = hits[:, 0] - x, hits[:, 1] - y
    t = dx * ux + dy * uy  # along the wall
    s = dx * -uy + dy * ux  # across it
    band = (np.abs(s) <= WALL_BAND_M) & (np.abs(t) <= door.width / 2 + JAMB_SEARCH_M)
    if not band.any():
        return None
    face = float(np.median(s[band]))
    ends = band & (np.abs(s - face) <= JAMB_DEPTH_M)
    before, after = t[ends & (t < 0)], t[ends & (t > 0)]
    if not len(before) or not len(after):
        return None
    low, high = float(before.max()), float(after.min())
    width = high - low
    if not robot_width + 2 * SIDE_M <= width <= door.width + JAMB_SEARCH_M:
        return None
    middle = (low + high) / 2
    return middle if abs(middle) <= MAX_SHIFT_M else None


class Sightings:
    """The latest MIN_SIGHTINGS middles seen of each doorway, by door id, bounded by the
    plan's doors; each revolution counted once, however many missions read it. Not
    thread-safe: the navigator holds its lock round it."""

    def __init__(self) -> None:
        self._seen: dict[str, collections.deque[float]] = {}
        self._medians: dict[str, float] = {}
        self._last_at: float | None = None

    def see(self, doorways: Iterable[Doorway], revolution: Revolution,
            robot_width: float) -> dict[str, float]:  # fmt: skip
        """The doorways within SIGHT_M that `revolution` shows: those whose middle moved
        by MOVED_M or more, with the middle now (metres along the wall from the plan's)."""
        if revolution.taken_at == self._last_at:
            return {}
        self._last_at = revolution.taken_at
        if revolution.turned:
            return {}
        moved = {}
        for doorway in doorways:
            if math.dist(revolution.seen_from, doorway.door.at) > SIGHT_M:
                continue
            (mx, my), (ux, uy) = revolution.moved, doorway.along
            if abs(mx * ux + my * uy) > SMEAR_M:
                continue
            found = opening_middle(doorway, revolution.hits, robot_width)
            if found is None:
                continue
            door_id = doorway.door.id
            seen = self._seen.setdefault(door_id, collections.deque(maxlen=MIN_SIGHTINGS))
            seen.append(found)
            if len(seen) < MIN_SIGHTINGS or max(seen) - min(seen) > AGREE_M:
                continue
            median = statistics.median(seen)
            if abs(median - self._medians.get(door_id, 0.0)) >= MOVED_M:
                self._medians[door_id] = median
                moved[door_id] = median
        return moved
