"""A revolution swept while the robot moves, put back as if taken at once from its end
(missions/deskewing.py), and a revolution the builder is told to draw only if matched."""

from __future__ import annotations

import math

import numpy as np

from giraff_console.missions.deskewing import deskewed
from giraff_console.planning.map_building import MapBuilder
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import Sweep, furnished_room, long_corridor, ray_cast

BEAMS = 360


def _swept(began: Pose, ended: Pose) -> tuple[Sweep, np.ndarray]:
    """A revolution the sensor sweeps clockwise from its front while the robot goes
    steadily from `began` to `ended`, as the simulator's lidar takes it; and where each
    beam's hit really is (map frame, inf where nothing was met)."""
    walls = furnished_room()
    bearings = -np.arange(BEAMS) * math.tau / BEAMS  # clockwise from the front
    beams, hits = [], []
    for index, bearing in enumerate(bearings):
        share = (index + 1) / BEAMS
        turn = math.remainder(ended.heading - began.heading, math.tau)
        at = Pose(began.x + share * (ended.x - began.x), began.y + share * (ended.y - began.y),
                  began.heading + share * turn)  # fmt: skip
        distance = ray_cast(walls, at, np.array([bearing]), 12.0).beams[0][0]
        wrapped = math.remainder(bearing, math.tau)
        beams.append((distance, wrapped))
        angle = at.heading + bearing
        hits.append((at.x + distance * math.cos(angle), at.y + distance * math.sin(angle)))
    return Sweep(12.0, tuple(beams)), np.array(hits)


def _placed(beams: np.ndarray, pose: Pose) -> np.ndarray:
    """Each beam's hit in the map frame (beams that met nothing left out)."""
    beams = beams[np.isfinite(beams[:, 0])]
    angle = pose.heading + beams[:, 1]
    return np.column_stack([pose.x + beams[:, 0] * np.cos(angle),
                            pose.y + beams[:, 0] * np.sin(angle)])  # fmt: skip


def test_each_beam_is_put_where_it_was_seen_from():
    # A fifth of a second at 0.25 m/s, turning 15 degrees a second: the operator's
    # curve (tests/teaching/operator.py), at the most the mapping lays in.
    began = Pose(4.0, 2.5, math.radians(30))
    ended = Pose(4.0 + 0.05 * math.cos(math.radians(31.5)),
                 2.5 + 0.05 * math.sin(math.radians(31.5)), math.radians(33))  # fmt: skip
    scan, truth = _swept(began, ended)
    seen = np.isfinite(np.array(scan.beams)[:, 0])
    assert seen.sum() > 300
    as_taken = _placed(np.array(scan.beams), ended)
    put_back = _placed(deskewed(scan, began, ended).beams, ended)
    raw_off = np.hypot(*(as_taken - truth[seen]).T)
    off = np.hypot(*(put_back - truth[seen]).T)
    # Drawn at the end's pose, the first beams are centimetres off; deskewed, each is
    # off by what the robot moves in one sample's time at most (the sweep's share is
    # taken from the bearing, a sample early).
    assert raw_off.max() > 0.1, raw_off.max()
    assert off.max() < 0.001, off.max()


def test_a_beam_that_met_nothing_stays_so_and_a_robot_standing_changes_nothing():
    pose = Pose(1.0, 1.0, 0.5)
    scan = Sweep(12.0, ((math.inf, 0.3), (2.0, -1.0), (3.5, 2.0)))
    beams = deskewed(scan, pose, pose).beams
    assert math.isinf(beams[0, 0]) and math.isclose(beams[0, 1], 0.3)
    np.testing.assert_allclose(beams[1:], [(2.0, -1.0), (3.5, 2.0)], atol=1e-12)
    assert deskewed(Sweep(12.0, ()), pose, pose).beams.shape == (0, 2)


def test_a_revolution_to_be_drawn_only_if_matched_is_left_out_when_it_is_not():
    corridor = long_corridor()
    bearings = np.radians(np.arange(-180.0, 180.0, 1.0))
    builder = MapBuilder()
    first = builder.add(
        Pose(5.0, 1.0, 0.0), ray_cast(corridor, Pose(5.0, 1.0, 0.0), bearings, 12.0), 0.0
    )
    assert first.drawn
    revision, correction = builder.revision, builder.correction
    before = builder.grid().cells.copy()
    # The filter says the robot stands 40 degrees off where it does (beyond any search):
    # no pose fits, and the revolution is not drawn at the filter's.
    truly = Pose(5.0, 1.0, 0.0)
    said = Pose(5.0, 1.0, math.radians(40.0))
    left = builder.add(said, ray_cast(corridor, truly, bearings - math.radians(40.0), 12.0),
                       0.2, unless_matched=True)  # fmt: skip
    assert not left.matched and not left.drawn, left.outcome
    assert builder.revision == revision and builder.correction == correction
    assert np.array_equal(builder.grid().cells, before)
    # Drawn when not asked to be matched first: the map changes.
    drawn = builder.add(said, ray_cast(corridor, truly, bearings - math.radians(40.0), 12.0), 0.4)
    assert drawn.drawn and builder.revision == revision + 1
