"""Rooms, doors and passages found in an Open-RMF level (floorplans/README.md, "Importing").

An RMF map does not say where one room ends and the next begins: it has walls, doors,
each fleet's lanes, and named vertices, the places robots are sent to. Our floor plan is
rooms joined by doors (thesis §2.6.2). They are found from what the map does say:

- A space is a part of the floor that walls, shut doors and gaps too narrow for the
  robot bound (rmf_walls.py); on a level without walls, a part of the lanes that doors
  cut off (rmf_lanes.py).
- Each named vertex is a room, in its space, at the vertex; one too close to a wall for
  the robot is moved clear of it. A space that a door leads to and that has no named
  vertex is a room of its own (`space-1`, ...) at its most interior point.
- Each RMF door joins the nearest room on one side of it to the nearest on the other.
- Rooms that share a space are joined by passages, doors with no wall: one halfway along
  each chain of lanes between two of them that passes no other room and no door, then
  as few more as join every room of the space to every other, each on the shortest way
  across the space between the nearest two not yet joined (Kruskal's minimum spanning
  tree, over the ways rmf_ways.py finds), at a point on it well clear of the walls.
- Rooms that nothing joins to the largest part of the level are left out.

Every choice the map did not make itself is told in a note, at the line it comes from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from giraff_console.planning.floorplan import Point, Where
from giraff_console.planning.plan_writing import millimetres
from giraff_console.planning.rmf_lanes import LaneGraph, chains, crossing, halfway
from giraff_console.planning.rmf_level import Level, Named, Places, RmfDoor, free_id
from giraff_console.planning.rmf_walls import SEAT_REACH_M, Floor
from giraff_console.planning.rmf_ways import Parts, Ways, space_ways
from giraff_console.planning.route_planner import CLEARANCE_M, ROBOT_RADIUS_M

# How far from a wall a room's point, or a passage, must be for the robot to stand there:
# its radius, the planner's margin (route_planner.py) and a cell of the spaces' grid more.
ROOM_CLEARANCE_M = ROBOT_RADIUS_M + CLEARANCE_M + 0.1
# Two named vertices nearer than this are drawn at one point: one place by two names.
SAME_POINT_M = 0.05
# A doorway the planner can pass: the robot and its margin either side, and a grid cell.
NARROWEST_DOOR_M = 2 * (ROBOT_RADIUS_M + CLEARANCE_M) + 0.05


@dataclass(frozen=True)
class Layout:
    """The floor plan's rooms and doors, and what was done to make them."""

    rooms: dict[str, tuple[Point, str | None]]  # id: (at, label)
    doors: list[dict[str, Any]]  # in the floor plan's schema
    start: str | None
    notes: list[tuple[Where, str]] = field(default_factory=list)
    # By room and door id, what it was made from: a passage, the first room it joins.
    made_from: dict[str, Where] = field(default_factory=dict)


@dataclass
class _Room:
    id: str
    at: Point
    place: int  # in the spaces' places
    named: Named | None  # None for a space's own room
    where: Where  # what it was made from: its vertex, or the door that leads to its space


@dataclass
class _Door:
    rooms: tuple[int, int]  # indices into the rooms
    plan: dict[str, Any]
    rmf: RmfDoor | None  # None for a passage


def find_rooms(level: Level, lanes: LaneGraph, floor: Floor | None, taken: set[str]) -> Layout:
    """The rooms and doors of `level`: on its floor's spaces when it has walls (`floor`),
    else on its lanes. `taken` holds the ids already used (rooms and RMF doors)."""
    return _Finder(level, lanes, floor, taken).layout()


class _Finder:
    def __init__(self, level: Level, lanes: LaneGraph, floor: Floor | None,
                 taken: set[str]) -> None:  # fmt: skip
        self.level, self.lanes, self.floor = level, lanes, floor
        self.places: Places = floor.places if floor is not None else lanes.places
        self.taken = set(taken)
        self.notes: list[tuple[Where, str]] = []
        self.rooms: list[_Room] = []
        self.doors: list[_Door] = []

    def layout(self) -> Layout:
        self._seat_named()
        sides = self._door_sides()
        self._space_rooms(sides)
        ways = {space: self._ways(space) for space in self._spaces()}
        self._rmf_doors(sides, ways)
        self._lane_passages()
        if self.floor is not None:
            self._lanes_through_walls()
        for found in ways.values():
            self._spanning(found)
        return self._connected()

    def note(self, where: Where, message: str) -> None:
        self.notes.append((where, message))

    def space(self, room: _Room) -> int:
        return int(self.places.space[room.place])

    def _spaces(self) -> list[int]:
        return sorted({self.space(room) for room in self.rooms})

    def _seat_named(self) -> None:
        """A room at each named vertex that is on the floor (or the lanes)."""
        for k, named in enumerate(self.level.named):
            same = [other for other in self.level.named[:k] if
                    math.dist(other.at, named.at) < SAME_POINT_M]  # fmt: skip
            if same:
                self.note(
                    named.where,
                    f"vertex {named.vertex} ({named.name!r}) is where vertex {same[0].vertex} "
                    f"({same[0].name!r}) is: rooms {same[0].id!r} and {named.id!r} are one "
                    "place, and a passage between them is there",
                )
            if self.floor is None:
                place = self.lanes.vertex_place[named.vertex]
                self.rooms.append(_Room(named.id, named.at, place, named, named.where))
                continue
            seat = self.floor.seat(named.at)
            if seat is None:
                self.note(
                    named.where,
                    f"vertex {named.vertex} ({named.name!r}) is off the level's floor, more "
                    f"than {SEAT_REACH_M:g} m from it: left out",
                )
                continue
            place, at = self._clear(named, seat)
            self.rooms.append(_Room(named.id, at, place, named, named.where))

    def _clear(self, named: Named, place: int) -> tuple[int, Point]:
        """Where a named vertex's room is: at the vertex, unless that is on a wall, off the
        floor or nearer a wall than the robot can stand; then at the nearest place of its
        space clear of the walls for the robot."""
        assert self.floor is not None
        clear = float(self.places.clearance[place])
        on_floor = self.floor.on_floor(named.at)
        if on_floor and clear >= ROOM_CLEARANCE_M:
            return place, named.at
        vertex = f"vertex {named.vertex} ({named.name!r})"
        where = f"{max(0.0, clear):.2f} m from a wall" if on_floor else "on a wall or off the floor"
        need = f"{ROOM_CLEARANCE_M:.2f} m clear of the walls for the robot"
        better = self.places.nearest(named.at, int(self.places.space[place]), ROOM_CLEARANCE_M)
        if better is None:
            unreachable = f"the robot may not reach room {named.id!r}"
            self.note(
                named.where,
                f"{vertex} is {where}, and no point of its space is {need}: {unreachable}",
            )
            return place, named.at if on_floor else _point(self.places.xy[place])
        at = _point(self.places.xy[better])
        moved = math.dist(at, named.at)
        self.note(
            named.where,
            f"{vertex} is {where}: room {named.id!r} is {moved:.2f} m from it, at "
            f"{_shown(at)}, {need}",
        )
        return better, at

    def _door_sides(self) -> dict[int, tuple[int, int]]:
        """The place on each side of each door that leads anywhere, by door index."""
        sides: dict[int, tuple[int, int]] = {}
        for i, door in enumerate(self.level.doors):
            if door.width == 0:
                self.note(
                    door.where,
                    f"door {door.id!r} has no width (its two ends are one point): left out",
                )
                continue
            if self.floor is None:
                found = self.lanes.door_sides.get(i)
                if found is None:
                    self.note(door.where, f"door {door.id!r} crosses no lane: left out")
                    continue
                sides[i] = found
                continue
            a, b = self.floor.door_sides[i]
            if a is None or b is None:
                self.note(door.where, f"door {door.id!r} leads off the level's floor: left out")
                continue
            sides[i] = (a, b)
        return sides

    def _space_rooms(self, sides: dict[int, tuple[int, int]]) -> None:
        """A room for each space that a door leads to and no named vertex is in."""
        roomed = set(self._spaces())
        for i, (a, b) in sides.items():
            door = self.level.doors[i]
            spaces = [int(self.places.space[a]), int(self.places.space[b])]
            if spaces[0] == spaces[1]:
                continue
            for space in spaces:
                if space in roomed:
                    continue
                roomed.add(space)
                place = self.places.centre(space)
                room_id = self._new_id("space", plain=False)
                at = _point(self.places.xy[place])
                self.rooms.append(_Room(room_id, at, place, None, door.where))
                made = f"it is room {room_id!r}, at {_shown(at)}"
                self.note(
                    door.where, f"door {door.id!r} leads to a space with no named vertex: {made}"
                )

    def _ways(self, space: int) -> Ways:
        """The shortest ways across the space from its rooms (rmf_ways.py)."""
        members = [i for i, room in enumerate(self.rooms) if self.space(room) == space]
        return space_ways(self.places, space, members, [self.rooms[i].place for i in members])

    def _rmf_doors(self, sides: dict[int, tuple[int, int]], ways: dict[int, Ways]) -> None:
        for i, (a, b) in sides.items():
            door = self.level.doors[i]
            ends = []
            for place in (a, b):
                found = ways.get(int(self.places.space[place]))
                if found is None:
                    break  # both sides are one space, and no room is in it
                # The nearest room on this side of the door's line, if any is: round a
                # door standing in open floor, a room behind it may be nearer.
                side = door.on_left(_point(self.places.xy[place]))
                ahead = [door.on_left(self.rooms[k].at) == side for k in found.rooms]
                ends.append(found.rooms[found.nearest(place, ahead)])
            if len(ends) < 2:
                self.note(
                    door.where,
                    f"door {door.id!r} has the same space on both sides, with no room in it: "
                    "left out",
                )
                continue
            if ends[0] == ends[1]:
                self.note(
                    door.where,
                    f"door {door.id!r} has room {self.rooms[ends[0]].id!r} on both sides, with "
                    "no wall between them: left out",
                )
                continue
            if self.floor is not None and door.width < NARROWEST_DOOR_M:
                self.note(
                    door.where,
                    f"door {door.id!r} is {door.width:.2f} m wide, too narrow for the robot "
                    f"(it needs {NARROWEST_DOOR_M:.2f} m): routes will not pass it",
                )
            x, y = door.centre
            at, width = [millimetres(x), millimetres(y)], millimetres(door.width)
            plan = {"between": [], "at": at, "width": width, "id": door.id}
            self._join(ends[0], ends[1], plan, door)

    def _join(self, a: int, b: int, plan: dict[str, Any], rmf: RmfDoor | None = None) -> None:
        a, b = min(a, b), max(a, b)  # between them in the rooms' order: the file's
        plan["between"] = [self.rooms[a].id, self.rooms[b].id]
        if rmf is None:
            plan["id"] = self._new_id(f"{self.rooms[a].id}-{self.rooms[b].id}")
        self.doors.append(_Door((a, b), plan, rmf))

    def _lane_passages(self) -> None:
        """A passage halfway along each chain of lanes between two rooms of one space that
        passes no other room and no door (the lanes are cut at doors)."""
        if self.floor is None:
            at_place = {room.place: i for i, room in enumerate(self.rooms)}
        else:
            at_place = {self.lanes.vertex_place[room.named.vertex]: i for i, room in
                        enumerate(self.rooms) if room.named is not None}  # fmt: skip
        lanes = self.lanes.places
        for (a, b), chain in chains(lanes, at_place).items():
            ra, rb = self.rooms[at_place[a]], self.rooms[at_place[b]]
            if self.space(ra) != self.space(rb):
                continue  # lanes through a wall: the floor is what the robot drives on
            x, y = self._settled(halfway([_point(lanes.xy[p]) for p in chain]), self.space(ra))
            at = [millimetres(x), millimetres(y)]
            self._join(at_place[a], at_place[b], {"between": [], "at": at})

    def _lanes_through_walls(self) -> None:
        """Note each lane that joins two spaces through a wall rather than a door: the
        robot goes round, by the doors."""
        assert self.floor is not None
        for lane in self.level.lanes:
            u, v = (self.level.points[end] for end in lane.ends)
            seats = [self.floor.seat(u), self.floor.seat(v)]
            if None in seats or any(crossing(u, v, door) for door in self.level.doors):
                continue
            if len({int(self.places.space[seat]) for seat in seats if seat is not None}) > 1:
                self.note(
                    lane.where,
                    f"the lane from vertex {lane.ends[0]} to vertex {lane.ends[1]} runs "
                    "through a wall (or a gap too narrow for the robot), where the map has no "
                    "door: the robot will not follow it there",
                )

    def _settled(self, point: Point, space: int) -> Point:
        """`point`, or the nearest point of `space` clear of the walls for the robot."""
        if self.floor is None:
            return point
        here = self.floor.seat(point)
        if (
            here is not None
            and self.places.space[here] == space
            and self.floor.on_floor(point)
            and self.places.clearance[here] >= ROOM_CLEARANCE_M
        ):
            return point
        better = self.places.nearest(point, space, ROOM_CLEARANCE_M)
        if better is None:
            better = self.places.nearest(point, space, 0.0)
        return point if better is None else _point(self.places.xy[better])

    def _spanning(self, ways: Ways) -> None:
        """Passages joining every room of a space to every other, on the shortest ways
        between the nearest rooms not yet joined (Kruskal), after the doors and lanes."""
        parts = Parts(ways.rooms)
        for door in self.doors:
            if all(room in parts.parent for room in door.rooms):
                parts.join(*door.rooms)
        for candidate in ways.candidates():
            a, b = (ways.rooms[k] for k in candidate.rooms)
            if parts.root(a) == parts.root(b):
                continue
            parts.join(a, b)
            x, y = self._midway(ways.way(candidate))
            self._join(a, b, {"between": [], "at": [millimetres(x), millimetres(y)]})

    def _midway(self, way: np.ndarray) -> Point:
        """A point of a way across a space for a passage: halfway along it, or the point
        of it nearest halfway that is clear of the walls for the robot."""
        xy = self.places.xy[way]
        clear = self.places.clearance[way]
        if np.isinf(clear).all():
            return halfway([_point(p) for p in xy])
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        order = np.argsort(np.abs(along - along[-1] / 2), kind="stable")
        good = clear[order] >= ROOM_CLEARANCE_M
        best = order[int(np.argmax(good))] if good.any() else int(np.argmax(clear))
        return _point(xy[best])

    def _connected(self) -> Layout:
        """The largest part of the level that doors and passages join; what is left out of
        it is told."""
        parts = Parts(range(len(self.rooms)))
        for door in self.doors:
            parts.join(*door.rooms)
        root = parts.root
        sizes: dict[int, int] = {}
        for i in range(len(self.rooms)):
            sizes[root(i)] = sizes.get(root(i), 0) + 1
        # The largest part; of parts alike, the one with the first room (dicts keep order).
        kept = max(sizes, key=lambda part: sizes[part], default=None)
        rooms: dict[str, tuple[Point, str | None]] = {}
        for i, room in enumerate(self.rooms):
            named = room.named
            if root(i) == kept:
                label = named.name if named is not None and named.name != room.id else None
                rooms[room.id] = ((millimetres(room.at[0]), millimetres(room.at[1])), label)
            elif named is not None:
                self.note(
                    named.where,
                    f"vertex {named.vertex} ({named.name!r}) is cut off from the rest of the "
                    "level: no door, opening the robot can pass or lane leads to room "
                    f"{room.id!r}; left out",
                )
        made_from = {room.id: room.where for room in self.rooms if room.id in rooms}
        doors = []
        for door in self.doors:
            if root(door.rooms[0]) == kept:
                doors.append(door.plan)
                first = self.rooms[door.rooms[0]].where
                made_from[door.plan["id"]] = door.rmf.where if door.rmf is not None else first
            elif door.rmf is not None:
                self.note(
                    door.rmf.where,
                    f"door {door.rmf.id!r} leads only to rooms cut off from the rest of the "
                    "level: left out",
                )
        chargers = [room.id for room in self.rooms if room.id in rooms and room.named is not None
                    and room.named.charger]  # fmt: skip
        start = chargers[0] if chargers else next(iter(rooms), None)
        return Layout(rooms, doors, start, self.notes, made_from)

    def _new_id(self, wanted: str, plain: bool = True) -> str:
        """An id of `wanted` no other room or door has (rmf_level.free_id), now taken."""
        found = free_id(wanted, self.taken, plain)
        self.taken.add(found)
        return found


def _point(xy: Any) -> Point:
    return (float(xy[0]), float(xy[1]))


def _shown(point: Point) -> str:
    return f"[{millimetres(point[0])}, {millimetres(point[1])}]"
