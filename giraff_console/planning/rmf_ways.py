"""The shortest ways across one space of an Open-RMF level between its rooms.

rmf_spaces.py joins the rooms of a space by passages on the shortest ways between them
(Kruskal's minimum spanning tree over the distances along the floor). One search from
all the rooms at once (a multi-source Dijkstra) finds for every place its nearest room
and the way there, which parts the floor into a region round each room. Each link where
two regions meet is a candidate way between their rooms: from one room to the link and
on to the other. The minimum spanning tree of these candidates is one of the distances
between every pair of rooms (Mehlhorn, "A faster approximation algorithm for the Steiner
problem in graphs", 1988), and it takes one search's time and memory however many rooms
there are: a search from each room took time and memory that grew with rooms x places,
gigabytes for an airport hall with a few hundred named places.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from giraff_console.planning.rmf_level import Places


@dataclass(frozen=True)
class Candidate:
    """A way between two rooms through the link where their regions meet."""

    length: float  # metres along the floor
    rooms: tuple[int, int]  # as the caller numbers them
    link: tuple[int, int]  # local places: the first in the first room's region


@dataclass(frozen=True)
class Ways:
    """For each place of a space, its nearest room and the way back to it."""

    rooms: list[int]  # the space's rooms, as the caller numbers them
    inside: np.ndarray  # the space's places: local place -> place of all the places
    local: np.ndarray  # place of all the places -> local place, -1 outside the space
    links: Any  # the space's links (scipy csr_array), between local places
    distance: np.ndarray  # local place -> metres to its nearest room
    previous: np.ndarray  # local place -> the place before it on the way from that room
    owner: np.ndarray  # local place -> its nearest room (an index into `rooms`), -1 if none
    at: np.ndarray  # each room's local place

    def candidates(self) -> list[Candidate]:
        """For each pair of rooms whose regions meet (or that stand on one place), the
        shortest way through where they meet; shortest first."""
        found: dict[tuple[int, int], Candidate] = {}
        at: dict[int, int] = {}
        for k, place in enumerate(self.at.tolist()):
            if place in at:  # two rooms on one place: no way between them but that place
                found[(at[place], k)] = Candidate(0.0, (at[place], k), (place, place))
            at.setdefault(place, k)
        links = self.links.tocoo()
        first, second, length = links.row, links.col, links.data
        a, b = self.owner[first], self.owner[second]
        meet = (first < second) & (a >= 0) & (b >= 0) & (a != b)
        cost = self.distance[first] + length + self.distance[second]
        order = np.flatnonzero(meet)[np.argsort(cost[meet], kind="stable")]
        for k in order.tolist():
            pair = (int(min(a[k], b[k])), int(max(a[k], b[k])))
            if pair not in found:
                link = (int(first[k]), int(second[k]))
                found[pair] = Candidate(float(cost[k]), pair, link if a[k] < b[k] else link[::-1])
        return sorted(found.values(), key=lambda c: (c.length, c.rooms))

    def way(self, candidate: Candidate) -> np.ndarray:
        """The candidate's way, from its first room to its second (places of all the
        places)."""
        there, back = self._back(candidate.link[0]), self._back(candidate.link[1])
        local = there[::-1] + (back[1:] if candidate.link[0] == candidate.link[1] else back)
        return self.inside[np.array(local, np.int64)]

    def nearest(self, place: int, allowed: Iterable[bool]) -> int:
        """The room (an index into `rooms`) nearest `place` along the floor of those
        `allowed`; the nearest of all if none is."""
        ok = np.array(list(allowed), bool)
        here = int(self.local[place])
        if ok[self.owner[here]]:
            return int(self.owner[here])
        distance = dijkstra(self.links, directed=False, indices=here)
        away = distance[self.at] + ~ok * 1e9
        return int(np.argmin(away))

    def _back(self, place: int) -> list[int]:
        """The local places from `place` back to its nearest room."""
        way = [place]
        while self.previous[way[-1]] >= 0:
            way.append(int(self.previous[way[-1]]))
        return way


def space_ways(places: Places, space: int, rooms: list[int], at: list[int]) -> Ways:
    """The ways across `space` from its `rooms`, which stand on the places `at`."""
    inside = np.flatnonzero(places.space == space)
    local = np.full(len(places.space), -1, np.int64)
    local[inside] = np.arange(inside.size)
    links = places.links[inside, :][:, inside]
    sources = local[np.array(at, np.int64)]
    distance, previous, source = dijkstra(links, directed=False, indices=sources,
                                          min_only=True, return_predecessors=True)  # fmt: skip
    # The first room on each place owns it (a second on the same place is joined to it).
    room_of = np.full(inside.size, -1, np.int64)
    room_of[sources[::-1]] = np.arange(len(rooms))[::-1]
    owner = np.where(source >= 0, room_of[np.maximum(source, 0)], -1)
    return Ways(rooms, inside, local, links, distance, previous, owner, sources)


class Parts:
    """Which rooms are joined to which, through doors and passages (union-find)."""

    def __init__(self, rooms: Iterable[int]) -> None:
        self.parent = {room: room for room in rooms}

    def root(self, room: int) -> int:
        while self.parent[room] != room:
            self.parent[room] = self.parent[self.parent[room]]
            room = self.parent[room]
        return room

    def join(self, a: int, b: int) -> None:
        self.parent[self.root(a)] = self.root(b)
