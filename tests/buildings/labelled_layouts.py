"""The floor layouts of the labelled scans (labelled_scans.py): boxes of floor, which room
each belongs to, and the openings between them, drawn from a seeded generator per kind.

A room is one or more boxes (`Space`), their walls on the boxes' edges. Two boxes of one
room are joined by an opening wider than a door (or by their whole shared wall, as the
arms of an L-shaped hall are); two rooms by a door. The rule a person goes by, and the
truth is labelled by: an opening up to `MAX_DOOR_M` wide is a door (a double door at
most), one wider is a way within one room (an archway, an alcove, a dining area open to
its kitchen). Doors are drawn 0.75 to 1.3 m and wide openings 1.6 to 2.5 m, clear of the
rule's line by more than the cell or two a scan's ragged jambs add or take; doors are
not drawn narrower than 0.75 m, as the route planner needs a way wider than 0.7 m for
the robot (route_planner.py) and a room behind a 0.7 m door is one it cannot reach.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from giraff_console.planning.room_openings import MAX_DOOR_M

Box = tuple[float, float, float, float]  # x0, y0, x1, y1: the walls' centre lines, metres
FULL = 0.0  # an opening's width: the whole of the shared wall


@dataclass(frozen=True)
class Space:
    room: str  # the room it is part of: the truth's label
    kind: str  # how it is furnished (labelled_scans.FURNISH)
    box: Box


@dataclass(frozen=True)
class Opening:
    a: int  # the two spaces' indices
    b: int
    width: float  # FULL for the whole shared wall
    at: float = 0.5  # where along the shared wall, 0 to 1


@dataclass(frozen=True)
class Layout:
    name: str
    kind: str
    spaces: tuple[Space, ...]
    openings: tuple[Opening, ...]
    columns: tuple[Box, ...] = ()  # the building's own pillars, in both versions


class _Plan:
    """A layout being drawn up."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng
        self.spaces: list[Space] = []
        self.openings: list[Opening] = []
        self.columns: list[Box] = []

    def space(self, room: str, kind: str, box: Box) -> int:
        self.spaces.append(Space(room, kind, box))
        return len(self.spaces) - 1

    def door(self, a: int, b: int, wide: bool = False, narrow: bool = False) -> None:
        width = (
            self.rng.uniform(1.2, 1.3) if wide else self.rng.uniform(0.75, 0.8 if narrow else 1.0)
        )
        assert width <= MAX_DOOR_M
        self.openings.append(Opening(a, b, round(width, 2), round(self.rng.uniform(0.3, 0.7), 2)))

    def open(self, a: int, b: int, full: bool = False) -> None:
        assert self.spaces[a].room == self.spaces[b].room, "a wide opening is within a room"
        width = FULL if full else round(self.rng.uniform(1.6, 2.5), 2)
        self.openings.append(Opening(a, b, width, 0.5))

    def done(self, name: str, kind: str) -> Layout:
        return Layout(name, kind, tuple(self.spaces), tuple(self.openings), tuple(self.columns))


def _u(rng: np.random.Generator, low: float, high: float) -> float:
    return round(float(rng.uniform(low, high)), 2)


def care_wing(rng: np.random.Generator, name: str) -> Layout:
    """A corridor of bedrooms each side, each with an en-suite in its far corner (the
    bedroom an L round it), and a day room through a double door at the end."""
    p = _Plan(rng)
    width, depth = _u(rng, 1.8, 2.4), _u(rng, 4.6, 5.4)
    count = int(rng.integers(4, 7))
    rooms = [_u(rng, 3.6, 4.4) for _ in range(count)]
    length = sum(rooms)
    corridor = p.space("corridor", "corridor", (0, 0, length, width))
    for side, (y0, y1) in enumerate(((width, width + depth), (-depth, 0))):
        x = 0.0
        for i, room_w in enumerate(rooms):
            name_i, suite = f"bedroom-{side}{i}", f"ensuite-{side}{i}"
            far = (y1 - 2.2, y1) if side == 0 else (y0, y0 + 2.2)
            near = (y0, far[0]) if side == 0 else (far[1], y1)
            main = p.space(name_i, "bedroom", (x, near[0], x + room_w, near[1]))
            side_box = p.space(name_i, "bedroom", (x + 2.0, far[0], x + room_w, far[1]))
            ensuite = p.space(suite, "ensuite", (x, far[0], x + 2.0, far[1]))
            p.open(main, side_box, full=True)
            p.door(corridor, main)
            p.door(main, ensuite, narrow=True)
            x += room_w
    day = p.space("day-room", "dining", (length, -depth, length + _u(rng, 6, 8), width + depth))
    p.door(corridor, day, wide=True)
    return p.done(name, "care wing")


def office(rng: np.random.Generator, name: str) -> Layout:
    """Small offices off a corridor, an open-plan area, a meeting room and a kitchenette."""
    p = _Plan(rng)
    width, depth = _u(rng, 1.8, 2.2), _u(rng, 3.6, 4.2)
    small = [_u(rng, 2.8, 3.4) for _ in range(int(rng.integers(5, 8)))]
    open_w = _u(rng, 9, 12)
    length = sum(small) + open_w
    corridor = p.space("corridor", "corridor", (0, 0, length, width))
    x = 0.0
    for i, w in enumerate(small):
        p.door(corridor, p.space(f"office-{i}", "office", (x, width, x + w, width + depth)))
        x += w
    area = p.space("open-plan", "open-plan", (x, width, length, width + _u(rng, 7, 9)))
    p.door(corridor, area, wide=True)
    x = 0.0
    south = [("meeting", "meeting", _u(rng, 5, 6)), ("kitchenette", "kitchen", _u(rng, 2.6, 3.2)),
             ("wc-1", "wc", 2.0), ("wc-2", "wc", 2.0)]  # fmt: skip
    south += [(f"office-s{i}", "office", _u(rng, 2.8, 3.4)) for i in range(3)]
    for room, kind, w in south:
        p.door(corridor, p.space(room, kind, (x, -depth, x + w, 0)), narrow=kind == "wc")
        x += w
    store = p.space("store", "utility", (x, -depth, length, 0))
    p.door(corridor, store)
    return p.done(name, "office")


def house(rng: np.random.Generator, name: str) -> Layout:
    """A house: a hall up the middle; a kitchen with its dining area through a wide
    opening and a living room on one side; bedrooms, a bathroom and a utility room on
    the other."""
    p = _Plan(rng)
    left, hall_w, right = _u(rng, 4.5, 6), _u(rng, 1.8, 2.4), _u(rng, 3.6, 4.5)
    kitchen_h, height = _u(rng, 4, 5), _u(rng, 10, 12)
    hall = p.space("hall", "hall", (left, 0, left + hall_w, height))
    kitchen = p.space("kitchen", "kitchen", (0, 0, left, kitchen_h))
    dining = p.space("kitchen", "dining", (-_u(rng, 3, 4), 0, 0, kitchen_h))
    living = p.space("living", "living", (0, kitchen_h, left, height))
    p.open(kitchen, dining)
    p.door(hall, kitchen)
    p.door(hall, living)
    p.door(kitchen, living)
    x0, x1, y = left + hall_w, left + hall_w + right, 0.0
    for room, kind, h in (("utility", "utility", 2.6), ("bed-1", "bedroom", (height - 5.2) / 2),
                          ("bathroom", "ensuite", 2.6), ("bed-2", "bedroom", 0.0)):  # fmt: skip
        top = height if kind == "bedroom" and room == "bed-2" else y + h
        p.door(hall, p.space(room, kind, (x0, y, x1, top)), narrow=kind in ("ensuite", "utility"))
        y = top
    return p.done(name, "house")


def open_hall(rng: np.random.Generator, name: str, arms: int) -> Layout:
    """An L-shaped (2 arms) or U-shaped (3) open hall, its arms one room, with rooms off
    its inner side through doors."""
    p = _Plan(rng)
    w, length, tall = _u(rng, 3, 4.5), _u(rng, 14, 20), _u(rng, 9, 13)
    base = p.space("hall", "hall", (0, 0, length, w))
    west = p.space("hall", "hall", (0, w, w, w + tall))
    p.open(base, west, full=True)
    east_x = length - w if arms == 3 else length
    if arms == 3:
        p.open(base, p.space("hall", "hall", (east_x, w, length, w + tall)), full=True)
    x, depth = w, _u(rng, 4, 5)
    while x + 3 <= east_x:
        room_w = min(_u(rng, 3, 4.5), east_x - x)
        room = p.space(f"room-{len(p.spaces)}", "office", (x, w, x + room_w, w + depth))
        p.door(base, room)
        if x == w:
            p.door(west, room)
        x += room_w
    return p.done(name, "L hall" if arms == 2 else "U hall")


def dining_hall(rng: np.random.Generator, name: str) -> Layout:
    """A large dining hall with a grid of columns and alcoves open to it, a kitchen through
    a double door and two toilets."""
    p = _Plan(rng)
    w, h = _u(rng, 14, 20), _u(rng, 10, 14)
    hall = p.space("hall", "dining", (0, 0, w, h))
    step = _u(rng, 4, 5)
    for cx in np.arange(step, w - step / 2, step):
        for cy in np.arange(step, h - step / 2, step):
            side = _u(rng, 0.4, 0.5)
            p.columns.append((cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2))
    x = _u(rng, 1, 2)
    while x + 3 < w - 1:  # alcoves along the north wall
        alcove_w = _u(rng, 2.2, 3)
        alcove = p.space("hall", "alcove", (x, h, x + alcove_w, h + _u(rng, 1.5, 2.5)))
        p.open(hall, alcove, full=bool(rng.integers(2)))
        x += alcove_w + _u(rng, 1.5, 3)
    kitchen = p.space("kitchen", "kitchen", (w, 0, w + _u(rng, 5, 7), h * 0.6))
    p.door(hall, kitchen, wide=True)
    y = h * 0.6
    for i in range(2):
        p.door(hall, p.space(f"wc-{i}", "wc", (w, y, w + 2.2, y + 2.0)), narrow=True)
        y += 2.0
    return p.done(name, "dining hall")


def suite(rng: np.random.Generator, name: str) -> Layout:
    """A block of 2 by 3 rooms, each neighbour joined by a door or by a wide opening: the
    rooms a wide opening joins are one room."""
    p = _Plan(rng)
    cols = [_u(rng, 3.5, 5) for _ in range(3)]
    rows = [_u(rng, 3.5, 5) for _ in range(2)]
    xs, ys = np.cumsum([0, *cols]), np.cumsum([0, *rows])
    pairs = [((r, c), (r, c + 1)) for r in range(2) for c in range(2)]
    pairs += [((0, c), (1, c)) for c in range(3)]
    wide = {pair for pair in pairs if rng.random() < 0.4}
    group = {(r, c): (r, c) for r in range(2) for c in range(3)}
    for a, b in sorted(wide):
        old, new = group[b], group[a]
        group = {k: new if v == old else v for k, v in group.items()}
    index = {}
    for r in range(2):
        for c in range(3):
            g = group[(r, c)]
            index[(r, c)] = p.space(f"room-{g[0]}{g[1]}", "living",
                                    (xs[c], ys[r], xs[c + 1], ys[r + 1]))  # fmt: skip
    for a, b in pairs:
        if (a, b) in wide or group[a] == group[b]:  # one room: no door within it
            p.open(index[a], index[b])
        else:
            p.door(index[a], index[b], wide=rng.random() < 0.3)
    return p.done(name, "rooms with wide openings")


def corridor_alcoves(rng: np.random.Generator, name: str) -> Layout:
    """A long corridor with alcoves open along one side, between rooms behind narrow
    doors, and rooms off the other side."""
    p = _Plan(rng)
    width, depth = _u(rng, 1.6, 2.0), _u(rng, 3.5, 4.5)
    corridor = p.space("corridor", "corridor", (0, 0, 1.0, width))
    x, length = 0.0, _u(rng, 30, 40)
    while x < length:
        room_w = _u(rng, 3, 4)
        north = p.space(f"room-n{len(p.spaces)}", "bedroom", (x, width, x + room_w, width + depth))
        p.door(corridor, north, narrow=True)
        south_x = x
        if rng.random() < 0.5:
            alcove_w = _u(rng, 1.6, 2.5)
            alcove = p.space("corridor", "alcove", (x, -_u(rng, 1.0, 1.8), x + alcove_w, 0))
            p.open(corridor, alcove, full=True)
            south_x = x + alcove_w if room_w - alcove_w > 2.5 else x + room_w
        if south_x < x + room_w:
            south = p.space(f"room-s{len(p.spaces)}", "office", (south_x, -depth, x + room_w, 0))
            p.door(corridor, south, narrow=True)
        x += room_w
    p.spaces[corridor] = Space("corridor", "corridor", (0, 0, x, width))
    return p.done(name, "corridor with alcoves")


KINDS: dict[str, Callable[[np.random.Generator, str], Layout]] = {
    "care-wing": care_wing,
    "office": office,
    "house": house,
    "l-hall": lambda rng, name: open_hall(rng, name, 2),
    "u-hall": lambda rng, name: open_hall(rng, name, 3),
    "dining-hall": dining_hall,
    "suite": suite,
    "corridor": corridor_alcoves,
}
# 22 maps: three of each kind, two of the halls.
MAPS = [(kind, seed) for kind in KINDS for seed in range(2 if "hall" in kind[:6] else 3)]


def layout(kind: str, seed: int) -> Layout:
    return KINDS[kind](np.random.default_rng([29, seed, len(kind)]), f"{kind}-{seed}")
