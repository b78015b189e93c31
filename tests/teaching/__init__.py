"""Buildings to teach the robot by driving them (issue 29): each a truth the simulator
is put in, where its dock is, the tour a person would drive to map it, and how many
rooms a person says it has."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from giraff_console.planning.floorplan import load_floorplan
from tests.buildings.scanned_home import scanned_home
from tests.teaching import flat


@dataclass(frozen=True)
class Teaching:
    name: str
    truth: Path  # the building's plan: the simulator's walls, doors and markers
    dock: tuple[float, float, float]  # x, y (m) and heading (degrees) of its dock
    tour: tuple[str, ...]  # the rooms driven to, in turn, from the dock, each marked
    real_rooms: int


def _flat(folder: Path) -> Teaching:
    return Teaching("flat", flat.write_flat(folder), flat.DOCK,
                    ("hall", "lounge", "bedroom", "kitchen"), len(flat.ROOMS))  # fmt: skip


def _home(folder: Path) -> Teaching:
    """tests/buildings/scanned_home's house, its 12 rooms found in its scan: the truth is
    that scan, ragged walls, furniture, clutter and all; the tour goes from the dock to
    the nearest room not yet visited, each in turn."""
    truth = scanned_home(folder)
    plan = load_floorplan(truth)
    assert plan.start is not None
    start = plan.rooms[plan.start]
    tour, here, left = [plan.start], start.at, set(plan.rooms) - {plan.start}
    while left:
        nearest = min(sorted(left), key=lambda room: math.dist(here, plan.rooms[room].at))
        tour.append(nearest)
        here = plan.rooms[nearest].at
        left.remove(nearest)
    return Teaching("home", truth, (*start.at, start.heading or 0.0), tuple(tour), 12)


BUILDINGS: dict[str, Callable[[Path], Teaching]] = {"flat": _flat, "home": _home}
