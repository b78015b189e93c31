"""A mapping run's choice of what to lay in (missions/mapping.py): after the heading may
have turned unseen (the casters after a turn on the spot), a revolution the matcher
cannot place is left out rather than drawn turned; but never more than MAX_LEFT_OUT in a
row, so that a drive the matcher cannot follow is still mapped."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from giraff_console.missions.mapping import MAX_LEFT_OUT, MappingRun
from giraff_console.planning.map_building import MapBuilder
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import furnished_room, ray_cast

BEARINGS = np.radians(np.arange(-180.0, 180.0, 1.0))
PERIOD_S = 1 / 5.5


@dataclass(frozen=True)
class Revolution:
    range_max: float
    beams: tuple[tuple[float, float], ...]
    taken_at: float
    sees_walls = True


def _run_with(turned_unseen: float, revolutions: int) -> MappingRun:
    """A robot standing in the furnished room: one revolution where the filter has it,
    then the filter's heading uncertain by a radian, and `revolutions` more taken
    `turned_unseen` radians from where the filter has it."""
    walls, at = furnished_room(), Pose(4.0, 2.0, 0.0)
    run = MappingRun(MapBuilder(), lambda text: None, at)
    run.close()  # laid in below, on this thread
    time = 0.0

    def tick_to(until: float, sigma: float) -> None:
        nonlocal time
        while time < until:
            time += 0.05
            run.pose(time, at, sigma)

    tick_to(PERIOD_S, 0.01)
    run.lay_in(Revolution(12.0, ray_cast(walls, at, BEARINGS, 12.0).beams, PERIOD_S))
    truly = Pose(at.x, at.y, at.heading + turned_unseen)
    for index in range(revolutions):
        stamp = (index + 2) * PERIOD_S
        tick_to(stamp + 0.01, 1.0)
        run.lay_in(Revolution(12.0, ray_cast(walls, truly, BEARINGS, 12.0).beams, stamp))
    return run


def test_a_revolution_the_matcher_cannot_place_is_left_out_while_the_heading_is_uncertain():
    # 50 degrees: beyond the matcher's widest search, so none is placed.
    run = _run_with(math.radians(50.0), MAX_LEFT_OUT)
    status = run.status()
    assert (status.scans, status.uncertain) == (1, MAX_LEFT_OUT)


def test_but_no_more_than_max_left_out_in_a_row():
    run = _run_with(math.radians(50.0), MAX_LEFT_OUT + 2)
    status = run.status()
    # The next after them is drawn at the filter's heading, and the map takes it as
    # its own: the one after fits it, and is drawn too.
    assert (status.scans, status.uncertain) == (3, MAX_LEFT_OUT)


def test_one_the_matcher_places_is_drawn_at_once():
    run = _run_with(math.radians(6.0), 3)
    assert (run.status().scans, run.status().uncertain) == (4, 0)
    # Drawn where the robot truly stands: the correction took the unseen turn out.
    assert abs(math.degrees(run.builder.correction.heading) - 6.0) < 0.5
