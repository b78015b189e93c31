"""Which wall of the plan each surveyed marker hangs on, found by the survey itself, and
the survey solved again on them (pose_graph.py).

Staff put markers up where it suits them and write nothing down, so the plan says where
its walls are but not which marker is on which. A survey solved without walls is good
to centimetres near the dock and drifts with the heading further on (metres at the end
of a 60 m corridor, with only the dock's 3 degrees to hold the map's turn), so snapping
each marker to its nearest wall would be wrong just where walls are needed.

So a marker is given a wall only when its own covariance allows no other: a wall passes
if the marker's centre may lie on its line and its facing may be the wall's normal, at
99 % (the two as one Mahalanobis distance, the wall's own sigmas added), and the marker
may lie within the wall's ends. One wall passing (or several along one line: a plan's
outlines hold a wall between two rooms once for each): the marker is held to it.
Several parallel ones, all facing the same way (a marker whose place is not yet sure
to within the room's width): it is held to that facing only. The heading's drift is
what makes far markers uncertain, and a facing held to a wall's is what removes it, so
a second solve with those makes the rest sure enough for their walls; `solve_on_walls`
goes round until nothing changes (three solves on the synthetic 30-room survey: no
walls, then 93 walls and 57 facings, then all 150 walls).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from giraff_console.robot.ekf import CHI_SQUARE, wrap
from giraff_console.robot.pose_graph import Survey, SurveyedMarker, SurveyResult, Wall, solve_survey
from giraff_console.robot.pose_graph_model import wrap_angles

# A wall passes for a marker at this confidence (chi-square, 2 degrees of freedom).
WALL_CONFIDENCE = 0.99
# ...and if the marker's centre lies within its ends, give or take this many sigmas.
ALONG_SIGMAS = 3.0
# Walls facing within this of each other face the same way, and lines this near are
# one: a plan's outlines hold each wall between two rooms (or a room and a corridor)
# once for each, cut at different doors.
SAME_FACING = math.radians(1.0)
SAME_LINE_M = 0.02
# Solves at most, the first (with only the walls the survey came with) included.
ROUNDS = 4


def assign_walls(markers: Mapping[int, SurveyedMarker], walls: Sequence[Wall]) -> dict[int, Wall]:
    """Each marker's wall where only one can be its own, or a wall whose facing only it
    takes where all that can be face the same way (sigma_m infinite); see the module
    docstring. Markers neither way are left out."""
    if not walls:
        return {}
    a = np.array([w.a for w in walls], dtype=float)
    b = np.array([w.b for w in walls], dtype=float)
    sigmas = np.array([(w.sigma_m, w.sigma_facing) for w in walls], dtype=float)
    length = np.linalg.norm(b - a, axis=1)
    # A face of a wall a grid holds is seen from one side only: a marker facing the
    # other way cannot hang on it (it is the far face of the wall behind the marker,
    # which with the near one would leave the marker held to neither).
    sides = np.array([math.nan if w.facing is None else w.facing for w in walls], dtype=float)
    usable = length > 0
    along = (b - a) / np.where(usable, length, 1.0)[:, None]
    left = np.stack([-along[:, 1], along[:, 0]], 1)
    gate = CHI_SQUARE[WALL_CONFIDENCE][2]
    assigned: dict[int, Wall] = {}
    for marker_id, marker in markers.items():
        p = np.array([marker.pose.x, marker.pose.y])
        cov = marker.covariance
        facing = np.array([math.cos(marker.pose.heading), math.sin(marker.pose.heading)])
        side_ok = np.isnan(sides) | (np.cos(sides - marker.pose.heading) > 0)
        normal = np.where((left @ facing >= 0)[:, None], left, -left)
        across = np.einsum("wi,wi->w", normal, p - a)
        off = wrap_angles(marker.pose.heading - np.arctan2(normal[:, 1], normal[:, 0]))
        # The covariance of (across, facing error): J cov J' with J = [n 0; 0 0 1].
        var_across = np.einsum("wi,ij,wj->w", normal, cov[:2, :2], normal) + sigmas[:, 0] ** 2
        cross = normal @ cov[:2, 2]
        var_facing = cov[2, 2] + sigmas[:, 1] ** 2
        det = var_across * var_facing - cross**2
        d2 = (across**2 * var_facing - 2 * across * off * cross + off**2 * var_across) / det
        t = np.einsum("wi,wi->w", along, p - a)
        spread = ALONG_SIGMAS * np.sqrt(np.einsum("wi,ij,wj->w", along, cov[:2, :2], along))
        passing = np.flatnonzero(usable & side_ok & (d2 <= gate) & (t >= -spread)
                                 & (t <= length + spread))  # fmt: skip
        if not len(passing):
            continue
        nearest = int(passing[np.argmin(d2[passing])])
        directions = np.arctan2(normal[passing, 1], normal[passing, 0])
        if any(abs(wrap(d - directions[0])) > SAME_FACING for d in directions):
            continue
        lines = np.einsum("wi,wi->w", normal[passing], a[passing])
        if np.ptp(lines) <= SAME_LINE_M:
            assigned[marker_id] = walls[nearest]
        else:
            assigned[marker_id] = replace(walls[nearest], sigma_m=math.inf)
    return assigned


def solve_on_walls(survey: Survey, walls: Sequence[Wall]) -> SurveyResult:
    """The survey solved with each marker held to its wall among `walls` (the plan's),
    as assign_walls finds them, solving again until they stop changing (at most ROUNDS
    solves). Walls the survey already gives a marker stay its own."""
    result = solve_survey(survey)
    found = dict(survey.walls)
    for _ in range(ROUNDS - 1):
        assigned = assign_walls(result.markers, walls)
        assigned.update(survey.walls)
        if assigned == found:
            break
        found = assigned
        result = solve_survey(replace(survey, walls=found), start=result)
    return result
