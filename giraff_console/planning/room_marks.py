"""Rooms named by the operator's marks (issue 29, "Rooms named as you go"): driving round
while the map is built, the operator types `mark kitchen` in each room, and the room of
the segmentation (room_segmentation.py) holding the robot's position then is named so.

A mark is a name and a map point. The room holding the point is named by it; a point on
furniture or a wall's ragged face takes the room of the nearest floor within
`MARK_REACH_M` (the robot stood on floor when the mark was made: the map has it a cell
or two off). Rooms no mark names keep room-N, in reading order, skipping any N a mark
took. What cannot be done is reported whole, each mark's problem a typed `MarkIssue`,
and nothing is named: a name that cannot be a room id (floorplan.is_id), a name given
twice, a mark on no room, two marks in one room.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

import cv2
import numpy as np

from giraff_console.planning.floorplan import Point, is_id
from giraff_console.planning.grid import OccupancyGrid

# A mark off the floor takes the room of the nearest floor this near.
MARK_REACH_M = 0.5
Mark = tuple[str, Point]


class MarkProblem(Enum):
    BAD_NAME = "not a room id"
    DUPLICATE = "a name marked twice"
    OFF_ROOMS = "on no room"
    SAME_ROOM = "a room marked twice"


@dataclass(frozen=True)
class MarkIssue:
    problem: MarkProblem
    name: str
    at: Point
    detail: str  # one line for the operator


def check_names(marks: Sequence[Mark]) -> list[MarkIssue]:
    """The marks whose names cannot name a room: not an id, or given twice."""
    issues: list[MarkIssue] = []
    seen: dict[str, Point] = {}
    for name, at in marks:
        if not is_id(name):
            issues.append(MarkIssue(MarkProblem.BAD_NAME, name, at,
                                    f"mark {name!r} at {_at(at)}: a room's name is 1 to 64 "
                                    "letters, digits, '-' or '_'"))  # fmt: skip
        elif name in seen:
            issues.append(MarkIssue(MarkProblem.DUPLICATE, name, at,
                                    f"mark {name!r} at {_at(at)}: {name!r} was marked "
                                    f"already, at {_at(seen[name])}"))  # fmt: skip
        else:
            seen[name] = at
    return issues


def marked_rooms(grid: OccupancyGrid, labels: np.ndarray,
                 marks: Sequence[Mark]) -> tuple[dict[int, str], list[MarkIssue]]:  # fmt: skip
    """Each marked room's label and its name, and the marks that name no room or share
    one."""
    named: dict[int, str] = {}
    where: dict[int, Mark] = {}
    issues: list[MarkIssue] = []
    for name, at in marks:
        label = _room_at(grid, labels, at)
        if label == 0:
            issues.append(MarkIssue(MarkProblem.OFF_ROOMS, name, at,
                                    f"mark {name!r} at {_at(at)} is on no room found: not "
                                    f"within {MARK_REACH_M:g} m of a room's floor"))  # fmt: skip
        elif label in where:
            first, first_at = where[label]
            said = (f"mark {name!r} at {_at(at)} is in the room marked {first!r} at "
                    f"{_at(first_at)}: one name a room")  # fmt: skip
            issues.append(MarkIssue(MarkProblem.SAME_ROOM, name, at, said))
        else:
            named[label], where[label] = name, (name, at)
    return named, issues


def room_names(order: Sequence[int], named: dict[int, str]) -> dict[int, str]:
    """Every room's name: its mark's, or room-N in reading order, N skipping names
    marked."""
    taken = set(named.values())
    names = dict(named)
    number = 0
    for label in order:
        if label in names:
            continue
        number += 1
        while f"room-{number}" in taken:
            number += 1
        names[label] = f"room-{number}"
    return names


def _room_at(grid: OccupancyGrid, labels: np.ndarray, at: Point) -> int:
    """The label of the room at map point `at`, or of the nearest within MARK_REACH_M;
    0 for none."""
    reach = math.ceil(MARK_REACH_M / grid.resolution)
    rows, cols = labels.shape
    col = math.floor((at[0] - grid.origin[0]) / grid.resolution)
    row = rows - 1 - math.floor((at[1] - grid.origin[1]) / grid.resolution)
    if not (math.isfinite(at[0]) and math.isfinite(at[1])):
        return 0
    top, left = max(0, row - reach), max(0, col - reach)
    window = labels[top : min(rows, row + reach + 1), left : min(cols, col + reach + 1)]
    if window.size == 0 or not window.any():
        return 0
    # Distance from each cell of the window to the mark's cell, the nearest room's wins.
    away = np.ones(window.shape, np.uint8)
    if 0 <= row - top < window.shape[0] and 0 <= col - left < window.shape[1]:
        away[row - top, col - left] = 0
        distance = cv2.distanceTransform(away, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    else:
        r, c = np.indices(window.shape)
        distance = np.hypot(r - (row - top), c - (col - left))
    distance = np.where(window > 0, distance, np.inf)
    best = np.unravel_index(int(np.argmin(distance)), window.shape)
    return int(window[best]) if distance[best] <= reach else 0


def _at(at: Point) -> str:
    return f"({at[0]:g}, {at[1]:g})"
