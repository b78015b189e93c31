"""Getting clear of a contact and trying again (issue 25, item 4).

A stall while driving (§2.3.2: motion commanded, the wheels not turning) means the robot
has touched something. On the imperfect simulator and on a real Giraff that is mostly a
door frame clipped because the robot was off its path: the casters turn it unseen after
a turn on the spot (§3.2.1.5), and a narrow doorway leaves a 0.6 m robot 10 cm either
side. Sometimes it is something the range finder did not see: it is a 70° fan at one
height, and a table's edge or a footrest passes under it. Giving up there ended a whole
night's patrol at its first doorway. Nav2 answers a failed path with recoveries (clear
the costmap, spin, back up, wait) before it gives up; a path mission here does, as
named steps (path_mission.py's stages):

1. stop at once: the board still holds the move that pushes against the frame;
2. back off the way it came: straight back along the last stretch it drove, which is
   free (the robot was just there), BACK_OFF_M or as far as that stretch runs
   straight behind it; with none behind it, as far as the plan's walls leave room;
3. on a second contact near the first, put it on the grid: something the plan does
   not know is there. Not on the first: a momentary stall of the wheels, or a frame
   clipped by a pose error, is passed on a retry, and a phantom obstacle in a
   corridor or a doorway would send the robot round it, or the long way. Never where
   a wall of the plan is, nor in a doorway, whose frames are what a robot a few
   centimetres off its line clips: then the pose was off, not the map;
4. know where it is again: the contact widens the estimate's uncertainty
   (localisation.touched), and with markers a look follows until one has fixed the
   pose since: the contact says the filter was wrong, most often about the casters;
5. plan again from there, and drive.

Bounded: MAX_CONTACTS contacts without getting PROGRESS_M past the last in between, or
MISSION_CONTACTS in all, end the mission as STALLED; each contact gives the progress
watch's time limit a fresh start (backing off and looking take time) but not its count
of replans, and every move is the executor's, within the same limits and guard as any
other (0.3 m, the deadman).
"""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from giraff_console.missions.progress_watch import PROGRESS_M
from giraff_console.planning.grid import OCCUPIED, OccupancyGrid
from giraff_console.planning.route_planner import ROBOT_RADIUS_M
from giraff_console.robot.odometry import Pose

Point = tuple[float, float]

# How far a robot backs off a contact: clear of the frame by more than the position
# error that put it there, and short enough to stay on the stretch it came along.
BACK_OFF_M = 0.25
# Less than this is not worth backing: a turn on the spot frees a disc from a frame.
MIN_BACK_OFF_M = 0.05
# Contacts in a row, without PROGRESS_M nearer in between, before the mission gives up:
# a second try passes a frame clipped by a pose error once the pose is known again; a
# third that touches too says the way is narrower than the map.
MAX_CONTACTS = 3
# Contacts in one mission, however far it got in between: each is a push of a second
# against something (the stall's time) and a fresh start of the progress watch's time.
MISSION_CONTACTS = 2 * MAX_CONTACTS
# Where the robot touched: ahead of its centre by its radius, within this many degrees
# either side of the way it was going, which a disc can only touch with its front.
CONTACT_SPREAD_DEG = 60.0
# What the robot touched is known only where it met it: put on the grid, it is taken to
# reach this much further (a box's half, a table's edge), so that the new way does not
# clip its far side.
FELT_EXTENT_M = 0.2
# A contact this near an earlier one is the same place touched again.
SAME_PLACE_M = 0.5
# A wall of the plan this near to where the robot touched explains the contact: the
# grid's cells are 5 cm, and a frame is drawn to within a cell of where it stands.
WALL_EXPLAINS_M = 0.10
# ...and so does a doorway's centre this near: the robot's disc reaches its frames.
DOORWAY_EXPLAINS_M = 0.6
# The trail of the robot's own recent poses, behind it, that backing off may follow.
TRAIL_M = 1.0
# A trail point this far off the straight line behind the robot ends the straight stretch.
TRAIL_TOLERANCE_M = 0.05


@dataclass(frozen=True)
class Contact:
    """One touch: where the robot stood, and where in front of it it touched."""

    pose: Pose
    point: Point
    explained: bool  # a wall of the plan is there: the pose was off, not the map
    again: bool  # an earlier contact of this run of them was at the same place

    @property
    def unknown_obstacle(self) -> bool:
        """Something the plan does not know is here: put it on the grid (step 3)."""
        return self.again and not self.explained


class Recovery:
    """The contacts of one mission and the trail it came along; see the module
    docstring. The mission feeds it its pose every tick (`trail`) and its distance left
    (`driven`), and asks it what to do when it touches something."""

    def __init__(self, radius: float = ROBOT_RADIUS_M) -> None:
        self.radius = radius
        self.contacts: list[Contact] = []
        self._in_a_row = 0
        self._best_left = math.inf  # at the last progress, or the last plan's start
        self._trail: collections.deque[Point] = collections.deque()

    def trail(self, pose: Pose) -> None:
        """Where the robot is now: the newest end of the trail, kept TRAIL_M long."""
        here = (pose.x, pose.y)
        if self._trail and math.dist(self._trail[-1], here) < 0.02:
            return
        self._trail.append(here)
        while len(self._trail) > 2 and _length(self._trail) > TRAIL_M:
            self._trail.popleft()

    def driven(self, left: float) -> None:
        """The plan under way has `left` metres to go: PROGRESS_M nearer than where the
        robot touched, and the contacts before no longer count as in a row."""
        if left <= self._best_left - PROGRESS_M:
            self._in_a_row = 0
            self._best_left = left

    def replanned(self, left: float) -> None:
        """A new plan of `left` metres: progress is measured along it from here, and
        after a back-off only past where the robot touched (BACK_OFF_M further on)."""
        self._best_left = left - BACK_OFF_M

    def touched(self, pose: Pose, walls: OccupancyGrid | None,
                doorways: Sequence[Point] = ()) -> Contact:  # fmt: skip
        """The robot, at `pose`, has stalled against something: the contact, counted.
        `doorways`: the plan's doors' centres."""
        self._in_a_row += 1
        point = (pose.x + self.radius * math.cos(pose.heading),
                 pose.y + self.radius * math.sin(pose.heading))  # fmt: skip
        recent = self.contacts[len(self.contacts) - self._in_a_row + 1 :]
        again = any(math.dist(point, before.point) <= SAME_PLACE_M for before in recent)
        in_doorway = any(math.dist(point, door) <= DOORWAY_EXPLAINS_M for door in doorways)
        explained = in_doorway or _wall_near_front(pose, self.radius, walls)
        contact = Contact(pose, point, explained, again)
        self.contacts.append(contact)
        return contact

    @property
    def exhausted(self) -> bool:
        """Too many contacts in a row, or in all, to try again."""
        return self._in_a_row >= MAX_CONTACTS or len(self.contacts) >= MISSION_CONTACTS

    @property
    def in_a_row(self) -> int:
        return self._in_a_row

    @property
    def touches(self) -> str:
        """How often it touched, in words, with a {} for where (the last place)."""
        if self._in_a_row >= MAX_CONTACTS:
            return f"{self._in_a_row} times in a row near {{}}"
        return f"{len(self.contacts)} times on the way, the last near {{}}"

    def back_off(self, pose: Pose, walls: OccupancyGrid | None = None) -> float:
        """How far to back straight up from `pose`: BACK_OFF_M, or as far as the trail
        it came along runs straight behind it. With no trail behind it (it touched as it
        set off, or turned since), as far as the plan's `walls` leave the robot's disc
        no nearer a wall than it stands now: a robot pinned against a wall by the
        casters' turn otherwise stayed there and touched it again from the same place
        on every try. 0 if it cannot back at all."""
        h = pose.heading
        behind = (-math.cos(h), -math.sin(h))
        reach = 0.0
        for point in reversed(self._trail):
            dx, dy = point[0] - pose.x, point[1] - pose.y
            along = dx * behind[0] + dy * behind[1]
            off = abs(-dx * behind[1] + dy * behind[0])
            if off > TRAIL_TOLERANCE_M or along < reach - TRAIL_TOLERANCE_M:
                break
            reach = max(reach, along)
        if reach < MIN_BACK_OFF_M and walls is not None:
            reach = _free_behind(pose, behind, self.radius, walls)
        distance = min(BACK_OFF_M, reach)
        return distance if distance >= MIN_BACK_OFF_M else 0.0


def _length(points: collections.deque[Point]) -> float:
    return sum(math.dist(a, b) for a, b in zip(points, list(points)[1:], strict=False))


def _free_behind(pose: Pose, behind: Point, radius: float, walls: OccupancyGrid) -> float:
    """How far straight back along `behind` the robot's disc comes no nearer the plan's
    walls than at `pose` (nor nearer than `radius`), in steps of half a cell."""
    step = walls.resolution / 2
    now = min(radius, _clearance((pose.x, pose.y), radius + step, walls))
    if now < walls.resolution:
        # Its centre on a wall (within a cell), or off the map, by the estimate: the
        # estimate is wrong, and nothing behind is known to be free.
        return 0.0
    reach = 0.0
    for distance in np.arange(step, BACK_OFF_M + step / 2, step):
        point = (pose.x + distance * behind[0], pose.y + distance * behind[1])
        if _clearance(point, radius + step, walls) < now - 1e-9:
            break
        reach = float(distance)
    return reach


def _clearance(point: Point, reach: float, walls: OccupancyGrid) -> float:
    """The distance from `point` to the nearest occupied cell of `walls` (its centre,
    less half a cell), looked for within `reach`; `reach` if there is none."""
    cells = math.ceil(reach / walls.resolution)
    try:
        row, col = walls.cell_of(*point)
    except ValueError:
        return 0.0  # off the map: not known to be free
    rows, cols = walls.cells.shape
    top, left = max(0, row - cells), max(0, col - cells)
    window = walls.cells[top : min(rows, row + cells + 1), left : min(cols, col + cells + 1)]
    occupied = np.argwhere(window == OCCUPIED)
    if not occupied.size:
        return reach
    x, y = walls.centre_of(0, 0)
    xs = x + (occupied[:, 1] + left) * walls.resolution
    ys = y - (occupied[:, 0] + top) * walls.resolution
    nearest = float(np.hypot(xs - point[0], ys - point[1]).min()) - walls.resolution / 2
    return min(reach, max(0.0, nearest))


def _wall_near_front(pose: Pose, radius: float, walls: OccupancyGrid | None) -> bool:
    """Whether the plan's own walls come within WALL_EXPLAINS_M of the front of a disc
    of `radius` at `pose` (its front arc, CONTACT_SPREAD_DEG either side)."""
    if walls is None:
        return False
    spread = math.radians(CONTACT_SPREAD_DEG)
    angles = pose.heading + np.linspace(-spread, spread, 9)
    reach = radius + WALL_EXPLAINS_M
    occupied = walls.cells == OCCUPIED
    rows, cols = occupied.shape
    for distance in np.arange(radius - WALL_EXPLAINS_M, reach + 1e-9, walls.resolution / 2):
        for angle in angles:
            try:
                row, col = walls.cell_of(pose.x + distance * math.cos(angle),
                                         pose.y + distance * math.sin(angle))  # fmt: skip
            except ValueError:
                continue  # off the map: no wall of the plan there
            if 0 <= row < rows and 0 <= col < cols and occupied[row, col]:
                return True
    return False
