"""A floor plan drawn in the terminal, for `floorplan show` (§2.6.2).

Each character covers a square of the grid, one cell wide and, since a terminal cell is
about twice as tall as it is wide, two cells tall: walls are solid, free space is blank
and unknown space is shaded. Each room's id is written at its `at` point, cut to fit.
"""

from __future__ import annotations

import math
import re

from giraff_console.planning.floorplan import FloorPlan
from giraff_console.planning.grid import FREE, OCCUPIED
from giraff_console.planning.route_planner import walls_of

WALL, OPEN, UNSEEN = "█", " ", "░"


def draw_plan(plan: FloorPlan, width: int = 100) -> list[str]:
    """The plan in at most `width` columns, one string per terminal line."""
    grid = walls_of(plan)
    if grid is None:
        raise ValueError(f"{plan.path}: no grid and no room outline to draw")
    rows, cols = grid.shape
    step = max(1, math.ceil(cols / max(1, width)))
    lines = []
    for top in range(0, rows, 2 * step):
        line = []
        for left in range(0, cols, step):
            block = grid.cells[top : top + 2 * step, left : left + step]
            occupied = block == OCCUPIED
            # A wall is drawn where one runs right across the character, so that a door
            # gap stays open and a corner of wall does not fill a room.
            if occupied.any(axis=0).all() or occupied.any(axis=1).all():
                line.append(WALL)
            elif (block == FREE).any():
                line.append(OPEN)
            else:
                line.append(UNSEEN)
        lines.append(line)
    for room_id, room in plan.rooms.items():
        row, col = grid.cell_of(*room.at)
        y, x = row // (2 * step), col // step
        room_width = _outline_width(room.outline, grid.resolution) // step or len(room_id)
        label = _label(room_id, max(1, room_width - 2))
        start = max(0, min(x - len(label) // 2, len(lines[y]) - len(label)))
        lines[y][start : start + len(label)] = label
    return ["".join(line).rstrip() for line in lines]


def _label(room_id: str, fits: int) -> str:
    """The id, or what tells it apart when it does not fit: room-101 becomes 101."""
    if len(room_id) <= fits:
        return room_id
    number = re.search(r"\d+\Z", room_id)
    if number and len(number.group()) <= fits:
        return number.group()
    return room_id[:fits]


def _outline_width(outline: tuple[tuple[float, float], ...] | None, resolution: float) -> int:
    """The outline's width in grid cells; 0 without one."""
    if not outline:
        return 0
    xs = [x for x, _ in outline]
    return int((max(xs) - min(xs)) / resolution)
