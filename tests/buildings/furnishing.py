"""Furniture and clutter for the labelled scans (labelled_scans.py), as a laser at knee
height sees them: solid sides (beds, wardrobes, counters, sofas, desks, a wheelchair,
washing machines) as blobs, tables and chairs as the specks of their legs. Furniture
stands against the walls or, in a room big enough, free in the middle with a way round
it; none within KEEP_CLEAR_M of a doorway, and never so deep from two facing walls
that the robot could not pass between (the route planner needs 0.7 m, legs.py).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from tests.buildings.labelled_layouts import Box, Layout
from tests.planning.scanned_rooms import WALL_M, WALL_SHADE

KEEP_CLEAR_M = 1.0
WAY_M = 1.2  # left between the deepest furniture of facing walls
# What stands against the walls of each kind of room: (along the wall, out from it).
AGAINST = {
    "bedroom": [(0.95, 2.0), (1.2, 0.6), (0.45, 0.45), (0.7, 0.7)],
    "ensuite": [(0.4, 0.7), (0.5, 0.45), (0.9, 0.9)],
    "wc": [(0.4, 0.7), (0.5, 0.45)],
    "corridor": [(0.8, 0.7), (0.6, 0.5)],  # a parked wheelchair, a laundry trolley
    "office": [(1.4, 0.7), (0.8, 0.45), (1.2, 0.4)],
    "open-plan": [(0.9, 0.45), (0.9, 0.45), (1.6, 0.4)],
    "meeting": [(1.6, 0.45)],
    "kitchen": [(2.6, 0.6), (0.7, 0.7), (1.8, 0.6)],
    "dining": [(1.8, 0.5), (1.2, 0.45)],
    "alcove": [(1.2, 0.5)],
    "living": [(2.0, 0.9), (0.8, 0.8), (1.4, 0.45), (0.8, 0.8)],
    "hall": [(1.0, 0.35), (1.8, 0.8)],
    "utility": [(0.6, 0.6), (0.6, 0.6), (0.6, 0.6), (1.5, 0.4)],  # washer, dryer, sink
}
# Free-standing: ("solid", along x, along y) or ("table", half the leg spacing, chairs).
MIDDLE = {
    "bedroom": [("table", 0.2, 0)],
    "office": [("table", 0.3, 1)],
    "open-plan": [("solid", 1.6, 1.4)] * 4 + [("table", 0.5, 4)],
    "meeting": [("table", 0.8, 6)],
    "kitchen": [("solid", 1.6, 0.8), ("table", 0.4, 4)],
    "dining": [("table", 0.35, 4)] * 6,
    "living": [("solid", 2.0, 0.9), ("table", 0.3, 0)],
    "hall": [("table", 0.4, 2)],
}


class Sheet(Protocol):
    image: np.ndarray

    def cell(self, x: float, y: float) -> tuple[int, int]: ...
    def fill(self, target: np.ndarray, box: Box, value: int) -> None: ...
    def disc(self, x: float, y: float, radius: float, shade: int) -> None: ...


def furnish(sheet: Sheet, plan: Layout, cuts: list[Box], rng: np.random.Generator) -> None:
    """Furniture and clutter drawn into `sheet`, KEEP_CLEAR_M either side of the openings
    cut through the walls (`cuts`) and a little beyond their ends."""
    taken = np.zeros(sheet.image.shape, dtype=bool)
    for x0, y0, x1, y1 in cuts:
        across_x = x1 - x0 < y1 - y0  # a wall running north-south
        dx, dy = (KEEP_CLEAR_M, 0.3) if across_x else (0.3, KEEP_CLEAR_M)
        sheet.fill(taken, (x0 - dx, y0 - dy, x1 + dx, y1 + dy), 1)
    for space in plan.spaces:
        x0, y0, x1, y1 = (space.box[0] + WALL_M / 2, space.box[1] + WALL_M / 2,
                          space.box[2] - WALL_M / 2, space.box[3] - WALL_M / 2)  # fmt: skip
        depth = {"w": 0.0, "e": 0.0, "s": 0.0, "n": 0.0}
        opposite = {"w": "e", "e": "w", "s": "n", "n": "s"}
        items = AGAINST.get(space.kind, []) + [(rng.uniform(0.15, 0.35),) * 2] * round(
            (x1 - x0) * (y1 - y0) / 5
        )  # boxes, bags and shoes along the walls
        for along, out in items:
            for _ in range(20):
                side = str(rng.choice(["w", "e", "s", "n"]))
                span = (y1 - y0) if side in "we" else (x1 - x0)
                room_across = (x1 - x0) if side in "we" else (y1 - y0)
                if along > span or out + depth[opposite[side]] > room_across - WAY_M:
                    continue
                u = rng.uniform(0, span - along)
                box = {"w": (x0, y0 + u, x0 + out, y0 + u + along),
                       "e": (x1 - out, y0 + u, x1, y0 + u + along),
                       "s": (x0 + u, y0, x0 + u + along, y0 + out),
                       "n": (x0 + u, y1 - out, x0 + u + along, y1)}[side]  # fmt: skip
                if _put(sheet, taken, box, 0.0):
                    depth[side] = max(depth[side], out)
                    break
        for item in MIDDLE.get(space.kind, []):
            for _ in range(20):
                if item[0] == "solid":
                    w, h = float(item[1]), float(item[2])
                else:
                    w = h = 2 * float(item[1]) + (0.9 if item[2] else 0.1)
                lo_x, lo_y = x0 + max(depth["w"], 0.3) + WAY_M, y0 + max(depth["s"], 0.3) + WAY_M
                hi_x, hi_y = (
                    x1 - max(depth["e"], 0.3) - WAY_M - w,
                    y1 - max(depth["n"], 0.3) - WAY_M - h,
                )
                if hi_x < lo_x or hi_y < lo_y:
                    break
                bx, by = rng.uniform(lo_x, hi_x), rng.uniform(lo_y, hi_y)
                box = (bx, by, bx + w, by + h)
                if not _put(sheet, taken, box, WAY_M, draw=item[0] == "solid"):
                    continue
                if item[0] == "table":
                    _table(sheet, (bx + w / 2, by + h / 2), float(item[1]), int(item[2]))
                break


def _put(sheet: Sheet, taken: np.ndarray, box: Box, around: float, draw: bool = True) -> bool:
    """Take `box` (and `around` it) if nothing has taken it, drawing it solid if `draw`."""
    r1, c0 = sheet.cell(box[0] - around, box[1] - around)
    r0, c1 = sheet.cell(box[2] + around, box[3] + around)
    if taken[max(0, r0) : r1, max(0, c0) : c1].any():
        return False
    sheet.fill(taken, box, 1)
    if draw:
        sheet.fill(sheet.image, box, WALL_SHADE)
    return True


def _table(sheet: Sheet, at: tuple[float, float], half: float, chairs: int) -> None:
    """A table's four legs `half` either side of `at`, and `chairs` chairs' round it."""
    x, y = at
    for dx, dy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
        sheet.disc(x + dx * half, y + dy * half, 0.025, WALL_SHADE)
    for i in range(chairs):
        angle = 2 * np.pi * i / chairs
        cx, cy = x + (half + 0.35) * np.cos(angle), y + (half + 0.35) * np.sin(angle)
        for dx, dy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
            sheet.disc(cx + dx * 0.18, cy + dy * 0.18, 0.025, WALL_SHADE)
