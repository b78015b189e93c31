"""An Open-RMF level's lanes as a graph of places, cut in two at every door.

On a level without walls the lanes are all there is to say where the spaces are: the
robots of every fleet drive along them, and a door across them separates one part of
the building from another. On a level with walls they still say which rooms the robots
go between directly: `chains` finds the ways along them from room to room, and
rmf_spaces.py joins such rooms by a passage `halfway` along the way.

Every lane counts, whatever its direction, and every fleet's: a route between rooms is
the building's, not one fleet's. Where a lane crosses a door it is cut, and each side
of the door is one place (a little way off it, on that side) that every lane crossing
the door on that side reaches: fleets whose lanes run side by side through one doorway
meet there. A door anywhere along a lane cuts it, however many vertices lie either side,
and a lane may cross several doors. Lanes are cut into steps of at most a metre, so
that there are places along them for a room to be put at, or a passage.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Collection
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from scipy.sparse import csr_array  # type: ignore[import-untyped]
from scipy.sparse.csgraph import connected_components  # type: ignore[import-untyped]

from giraff_console.planning.floorplan import Point
from giraff_console.planning.rmf_level import Level, Places, RmfDoor

STEP_M = 1.0
# How far off the door line each of its sides' places is: on its own side, not in it.
SIDE_M = 0.25
# A lane that ends this close to a door's line ends in the doorway: it reaches neither side.
ON_DOOR_M = 0.01


@dataclass(frozen=True)
class LaneGraph:
    places: Places
    vertex_place: dict[int, int]  # the place of each vertex on a lane, and of each named one
    door_sides: dict[int, tuple[int, int]]  # by door index: its two sides' places


def lane_graph(level: Level) -> LaneGraph:
    """The level's lanes (and its named vertices, lane or not) as places."""
    xy: list[Point] = []
    vertex_place: dict[int, int] = {}
    door_sides: dict[int, tuple[int, int]] = {}
    links: dict[tuple[int, int], float] = {}  # one link a pair, however many lanes share it

    def place(point: Point) -> int:
        xy.append(point)
        return len(xy) - 1

    def vertex(index: int) -> int:
        if index not in vertex_place:
            vertex_place[index] = place(level.points[index])
        return vertex_place[index]

    def sides(index: int) -> tuple[int, int]:
        if index not in door_sides:
            door = level.doors[index]
            nx, ny = (SIDE_M * n for n in door.normal)
            cx, cy = door.centre
            door_sides[index] = (place((cx + nx, cy + ny)), place((cx - nx, cy - ny)))
        return door_sides[index]

    def link(a: int, b: int) -> None:
        (ax, ay), (bx, by) = xy[a], xy[b]
        steps = max(1, math.ceil(math.hypot(bx - ax, by - ay) / STEP_M))
        chain = [a]
        for k in range(1, steps):
            chain.append(place((ax + (bx - ax) * k / steps, ay + (by - ay) * k / steps)))
        chain.append(b)
        for c, d in pairwise(chain):
            # Never 0: csgraph would read a link of length 0 as no link.
            links[(min(c, d), max(c, d))] = max(1e-6, math.dist(xy[c], xy[d]))

    for named in level.named:
        vertex(named.vertex)
    for lane in level.lanes:
        u, v = lane.ends
        start, end = level.points[u], level.points[v]
        length = math.dist(start, end)
        crossings = sorted(
            (*found, i)
            for i, door in enumerate(level.doors)
            if (found := crossing(start, end, door) or _touching(start, end, door)) is not None
        )
        here = vertex(u)
        for t, before, i in crossings:
            near, far = sides(i)[before], sides(i)[1 - before]
            if t * length > ON_DOOR_M:  # not a lane that starts in the doorway
                link(here, near)
            here = far
        if not crossings or (1 - crossings[-1][0]) * length > ON_DOOR_M:
            link(here, vertex(v))

    count = len(xy)
    pairs = np.array(list(links), dtype=np.int64).reshape(-1, 2)
    lengths = np.array(list(links.values()), dtype=float)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1]])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0]])
    graph = csr_array((np.concatenate([lengths, lengths]), (rows, cols)), shape=(count, count))
    _, space = connected_components(graph, directed=False)
    places = Places(np.array(xy, dtype=float).reshape(-1, 2), graph, space,
                    np.full(count, math.inf), STEP_M)  # fmt: skip
    return LaneGraph(places, vertex_place, door_sides)


def crossing(start: Point, end: Point, door: RmfDoor) -> tuple[float, int] | None:
    """Where the lane from `start` to `end` crosses `door`: the fraction of the way
    along the lane, and the side of the door it comes from (0: the left of the door's
    first end to its second, 1: the right). None if it does not cross it, or runs along
    it."""
    (px, py), (qx, qy) = door.ends
    ex, ey = end[0] - start[0], end[1] - start[1]
    fx, fy = qx - px, qy - py
    wx, wy = px - start[0], py - start[1]
    det = ex * fy - ey * fx
    if abs(det) < 1e-12:
        return None
    along_lane, along_door = (wx * fy - wy * fx) / det, (wx * ey - wy * ex) / det
    if not (0 <= along_lane <= 1 and 0 <= along_door <= 1):
        return None
    # Just before the crossing the lane is on the side where (door x point) has det's sign.
    return along_lane, 0 if det > 0 else 1


def _touching(start: Point, end: Point, door: RmfDoor) -> tuple[float, int] | None:
    """A lane that does not cross `door` but starts or ends within ON_DOOR_M of it ends in
    the doorway as one that crosses it there does: it arrives at the side it comes from
    or leaves from the side it goes to, whichever side of the line the vertex is drawn on
    (a junction drawn a millimetre past a door is in the doorway, not behind it)."""
    near = [_away(point, door) <= ON_DOOR_M for point in (start, end)]
    if near[0] == near[1]:
        return None  # clear of the door, or along it
    # As `crossing` tells it: the side the lane comes from (0: the door's left), which for
    # a lane leaving the doorway is the side opposite the one it goes to.
    if near[0]:
        return 0.0, 1 if door.on_left(end) else 0
    return 1.0, 0 if door.on_left(start) else 1


def _away(point: Point, door: RmfDoor) -> float:
    """Metres from `point` to the door's segment."""
    (px, py), (qx, qy) = door.ends
    fx, fy = qx - px, qy - py
    length2 = fx * fx + fy * fy
    along = ((point[0] - px) * fx + (point[1] - py) * fy) / length2 if length2 else 0.0
    t = min(1.0, max(0.0, along))
    return math.dist(point, (px + t * fx, py + t * fy))


def chains(lanes: Places, rooms: Collection[int]) -> dict[tuple[int, int], list[int]]:
    """For each pair of the places `rooms` (a < b) joined by lanes through no other of
    them, the shortest such chain of places, from a to b. The lanes are cut at doors, so
    no chain passes one."""
    links, ends = lanes.links, set(rooms)
    found: dict[tuple[int, int], list[int]] = {}
    for a in sorted(ends):
        # Dijkstra from a that stops at every other room: rooms end chains.
        distance, previous, queue = {a: 0.0}, {}, [(0.0, a)]
        while queue:
            d, v = heapq.heappop(queue)
            if d > distance[v] or (v != a and v in ends):
                continue
            for k in range(links.indptr[v], links.indptr[v + 1]):
                w, step = int(links.indices[k]), d + float(links.data[k])
                if step < distance.get(w, math.inf):
                    distance[w], previous[w] = step, v
                    heapq.heappush(queue, (step, w))
        for b in sorted(ends & distance.keys()):
            if b > a:
                chain = [b]
                while chain[-1] != a:
                    chain.append(previous[chain[-1]])
                found[(a, b)] = chain[::-1]
    return found


def halfway(chain: list[Point]) -> Point:
    """The point halfway along a polyline."""
    steps = [math.dist(a, b) for a, b in pairwise(chain)]
    left = sum(steps) / 2
    for (a, b), step in zip(pairwise(chain), steps, strict=True):
        if step >= left:
            t = left / step if step else 0.0
            return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
        left -= step
    return chain[-1]  # rounding left a sliver past the last step
