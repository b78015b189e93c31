"""Buildings to teach the robot by driving them (issue 29): each a truth the simulator
is put in, where its dock is, the tour a person would drive to map it, and how many
rooms a person says it has."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

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


BUILDINGS: dict[str, Callable[[Path], Teaching]] = {"flat": _flat}
