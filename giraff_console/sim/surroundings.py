"""What the floor plan does not show: boxes in the way and doors that are shut.

Blueprints "would probably not include obstacles such as furniture or people" (§2.1),
and a robot among people must notice what is "right in front of" it (§2.4). The thesis
would add "an infrared laser range finder ... to minimize the risk of crashing into
things" (§6); the simulator stands in for one (`range_finder.py`) and needs things for
it to find. An operator puts chairs and trolleys down and shuts doors here while the
robot runs; the range finder, the synthetic camera and a bumper check read them from
other threads, and the board's wheels stop against them as against the walls
(collision.py, which reads the same segments). So every change is made under a lock,
and readers get an immutable snapshot, rebuilt only when the revision has moved on, so
that reading it every tick costs next to nothing.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

# What a segment belongs to; the camera paints them differently.
BLOCK, CLOSED_DOOR = 0, 1
# `unblock` beside a box still finds it within this distance: a click on a map is
# seldom exactly on a 0.5 m square.
UNBLOCK_REACH_M = 0.5

Point = tuple[float, float]


@dataclass(frozen=True)
class Block:
    """A square box standing on the floor, axis-aligned: centre and side in metres."""

    x: float
    y: float
    size: float

    def corners(self) -> tuple[Point, Point, Point, Point]:
        """Counter-clockwise from the south-west corner."""
        h = self.size / 2
        x, y = self.x, self.y
        return (x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h)

    def distance_to(self, x: float, y: float) -> float:
        """How far (x, y) is from the square; zero on it or inside it."""
        h = self.size / 2
        return math.hypot(max(abs(x - self.x) - h, 0.0), max(abs(y - self.y) - h, 0.0))


@dataclass(frozen=True)
class Door:
    """A closed door: a segment across its doorway, from jamb `a` to jamb `b`."""

    a: Point
    b: Point

    def distance_to(self, x: float, y: float) -> float:
        """How far (x, y) is from the nearest point of the door."""
        (ax, ay), (bx, by) = self.a, self.b
        ex, ey = bx - ax, by - ay
        along = ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)
        along = min(max(along, 0.0), 1.0)
        return math.hypot(x - (ax + along * ex), y - (ay + along * ey))


@dataclass(frozen=True)
class Obstacles:
    """Everything at one revision, as segments ready for vectorised ray casting.

    Block edges come first, four per block, then one segment per door. `kinds` says
    BLOCK or CLOSED_DOOR per segment; `owners` numbers the block or door each segment
    belongs to, so that a ray's way out of a box can be found. The arrays are read-only.
    """

    revision: int
    starts: np.ndarray
    ends: np.ndarray
    kinds: np.ndarray
    owners: np.ndarray
    blocks: Mapping[str, Block]
    doors: Mapping[str, Door]


def cast_rays(
    x: float, y: float, dx: np.ndarray, dy: np.ndarray, starts: np.ndarray, ends: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where rays from (x, y) along unit directions (dx, dy) cross segments.

    Returns `t`, shape (rays, segments): how far along each ray each segment is crossed,
    in metres, inf where it is missed; and `s`: where on the segment, 0 at its start and
    1 at its end (meaningless where missed). The camera casts walls and obstacles with it,
    the range finder obstacles, so both see the same geometry.
    """
    edge = ends - starts  # (segments, 2)
    rel = starts - np.array([x, y])  # (segments, 2)
    denom = dx[:, None] * edge[None, :, 1] - dy[:, None] * edge[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rel[None, :, 0] * edge[None, :, 1] - rel[None, :, 1] * edge[None, :, 0]) / denom
        s = (rel[None, :, 0] * dy[:, None] - rel[None, :, 1] * dx[:, None]) / denom
    # A ray grazing along a segment (denom 0) does not stop at it, nor does one at the
    # segment it starts on (t ~ 0): a sensor touching a box still sees past that edge.
    valid = (np.abs(denom) > 1e-12) & (t > 1e-6) & (s >= 0) & (s <= 1)
    return np.where(valid, t, np.inf), s


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _build(revision: int, blocks: dict[str, Block], doors: dict[str, Door]) -> Obstacles:
    starts: list[Point] = []
    ends: list[Point] = []
    kinds: list[int] = []
    owners: list[int] = []
    for owner, block in enumerate(blocks.values()):
        corners = block.corners()
        for i in range(4):
            starts.append(corners[i])
            ends.append(corners[(i + 1) % 4])
        kinds += [BLOCK] * 4
        owners += [owner] * 4
    for owner, door in enumerate(doors.values(), start=len(blocks)):
        starts.append(door.a)
        ends.append(door.b)
        kinds.append(CLOSED_DOOR)
        owners.append(owner)
    return Obstacles(
        revision,
        _frozen(np.array(starts, dtype=np.float64).reshape(-1, 2)),
        _frozen(np.array(ends, dtype=np.float64).reshape(-1, 2)),
        _frozen(np.array(kinds, dtype=np.int8)),
        _frozen(np.array(owners, dtype=np.int32)),
        MappingProxyType(dict(blocks)),
        MappingProxyType(dict(doors)),
    )


class Surroundings:
    """Boxes and closed doors in the simulated building; thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._blocks: dict[str, Block] = {}
        self._doors: dict[str, Door] = {}
        self._numbered = 0
        self._revision = 0
        self._snapshot = _build(0, {}, {})

    # -- what the operator does ---------------------------------------------------------

    def block(self, x: float, y: float, size: float = 0.5) -> str:
        """Put down a square box of side `size` centred at (x, y); returns its id."""
        if not size > 0:
            raise ValueError(f"a block needs a positive size, not {size}")
        with self._lock:
            self._numbered += 1
            block_id = f"block-{self._numbered}"
            self._blocks[block_id] = Block(x, y, size)
            self._revision += 1
            return block_id

    def unblock(self, x: float, y: float) -> list[str]:
        """Take away the boxes that (x, y) is on, else the nearest one within 0.5 m of
        it; returns the ids taken away, none if nothing was there."""
        with self._lock:
            distances = {bid: b.distance_to(x, y) for bid, b in self._blocks.items()}
            removed = [bid for bid, distance in distances.items() if distance == 0.0]
            if not removed and distances:
                nearest = min(distances, key=distances.__getitem__)
                if distances[nearest] <= UNBLOCK_REACH_M:
                    removed = [nearest]
            for bid in removed:
                del self._blocks[bid]
            if removed:
                self._revision += 1
            return removed

    def close_door(self, door_id: str, a: Point, b: Point) -> None:
        """Shut the door `door_id` across its doorway, from jamb `a` to jamb `b`. Closing
        a door that is already shut puts it where `a` and `b` now say."""
        door = Door((float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
        if door.a == door.b:
            raise ValueError(f"door {door_id!r} needs two different jambs")
        with self._lock:
            self._doors[door_id] = door
            self._revision += 1

    def open_door(self, door_id: str) -> bool:
        """Open the door `door_id`; False if it was not shut."""
        with self._lock:
            if self._doors.pop(door_id, None) is None:
                return False
            self._revision += 1
            return True

    # -- what the sensors and the display read ------------------------------------------

    @property
    def revision(self) -> int:
        """Goes up by one with every change."""
        with self._lock:
            return self._revision

    def snapshot(self) -> Obstacles:
        """Everything as it is now; the same object until something changes."""
        with self._lock:
            if self._snapshot.revision != self._revision:
                self._snapshot = _build(self._revision, self._blocks, self._doors)
            return self._snapshot

    def segments(self) -> tuple[np.ndarray, np.ndarray]:
        """Starts and ends, shape (n, 2), of every box edge and closed door; read-only."""
        obstacles = self.snapshot()
        return obstacles.starts, obstacles.ends

    @property
    def blocks(self) -> Mapping[str, Block]:
        """The boxes by id, read-only, as they are now."""
        return self.snapshot().blocks

    @property
    def doors(self) -> Mapping[str, Door]:
        """The closed doors by id, read-only, as they are now."""
        return self.snapshot().doors

    def touches(self, x: float, y: float, radius: float) -> bool:
        """Whether a disc of `radius` at (x, y) overlaps a box or a closed door: what a
        bumper would feel, or a collision check would refuse."""
        obstacles = self.snapshot()
        things: tuple[Block | Door, ...] = (
            *obstacles.blocks.values(),
            *obstacles.doors.values(),
        )
        return any(thing.distance_to(x, y) <= radius for thing in things)
