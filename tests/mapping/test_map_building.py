"""The map built while driving: walls where they are, and held there by scan matching
against an odometry that drifts (2 % distance error, 1.5 degrees a metre)."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pytest

from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.planning.map_building import (
    MAX_BEAMS,
    MapBuilder,
    MapTooLarge,
    MatchedPose,
)
from giraff_console.planning.scan_matching import MatchOutcome
from giraff_console.planning.scan_outline import CLEAR_NO_HIT_M
from giraff_console.robot.odometry import Pose
from tests.mapping.buildings import (
    CORRIDOR_DRIVE,
    ROOM_DRIVE,
    WING_DRIVE,
    Sweep,
    Walls,
    box,
    care_home_wing,
    drifted,
    drive,
    furnished_room,
    long_corridor,
    score,
    sweeps,
    wall,
)

RATE = 5.5  # scans a second: an RPLIDAR A1's usual speed
DOOR_M = 0.8  # a care home's narrow door


def mapped(walls: Walls, route: Sequence[tuple[float, float]], drift: bool, matching: bool,
           seed: int = 1) -> tuple[MapBuilder, list[MatchedPose], list[Pose]]:  # fmt: skip
    """A map built along `route` at the true poses, or at drifting ones."""
    truth = drive(route, RATE)
    poses = drifted(truth, 0.02, 1.5) if drift else truth
    builder = MapBuilder(match_scans=matching)
    added = [
        builder.add(pose, scan, k / RATE)
        for k, (pose, scan) in enumerate(zip(poses, sweeps(walls, truth, 360, seed), strict=True))
    ]
    return builder, added, truth


def worst_error(added: list[MatchedPose], truth: list[Pose]) -> tuple[float, float]:
    """The worst distance (m) and heading (degrees) from the pose used to the true one."""
    pairs = list(zip(added, truth, strict=True))
    moved = max(math.dist((a.pose.x, a.pose.y), (t.x, t.y)) for a, t in pairs)
    turned = max(abs(math.remainder(a.pose.heading - t.heading, math.tau)) for a, t in pairs)
    return moved, math.degrees(turned)


def test_true_poses_draw_the_walls_where_they_are() -> None:
    builder, _, _ = mapped(care_home_wing(), WING_DRIVE, drift=False, matching=False)
    found = score(builder.grid(), care_home_wing())
    assert found.near_05 >= 0.98
    assert found.seen >= 0.6  # the backs of rooms not entered stay unseen


@dataclass(frozen=True)
class Bound:
    """The stated error of a map built with matching under drift."""

    near_05: float  # at least this fraction of occupied cells within 0.05 m of a wall
    near_10: float  # ... within 0.10 m
    seen: float  # at least this fraction of the wall length the true poses' map shows
    moved_m: float  # the pose used at most this far from the true one
    turned_deg: float  # ... and this far in heading


# Measured over seeds 1-5 (worst): the wing 0.85 / 1.00 / 0.88 / 0.06 m / 0.54 deg; the
# room 0.58 / 0.91 / 0.87 / 0.11 m / 0.45 deg. The room's drive starts outside its door
# facing one wall, which pins the pose across it only: the map can settle a few
# centimetres along that wall from the true frame (seed 5: 7.5 cm), whole and square
# but shifted, which the scores below count against it.
#
# Since the free floor stops at the nearer surface where neighbouring beams step in
# range (scan_outline.stepped: the simulator's lidar lost the walls beside doorways
# without it, the small flat's map 69 % within 0.10 m of the truth, 93 % with it), the
# room's seeds 2-4 are better (0.78 / 1.00 / 0.93-0.96) and seed 1 worse: 0.34 / 0.71
# / 0.88 / 0.16 m / 1.45 deg, its drive settling 0.16 m off while it enters the room;
# seed 5 0.59 / 0.93 / 0.95 / 0.11 m / 1.42 deg. The room's bound is that worst.
WING_BOUND = Bound(0.80, 0.99, 0.85, 0.08, 1.0)
ROOM_BOUND = Bound(0.30, 0.70, 0.80, 0.17, 1.5)


@pytest.mark.parametrize(
    ("walls", "route", "bound"),
    [(care_home_wing(), WING_DRIVE, WING_BOUND), (furnished_room(), ROOM_DRIVE, ROOM_BOUND)],
    ids=["care-home wing", "furnished room"],
)
@pytest.mark.parametrize("seed", [1, 5])
def test_matching_holds_the_map_to_the_walls_under_drift(
    walls: Walls, route: list, bound: Bound, seed: int
) -> None:
    truth_map = score(mapped(walls, route, drift=False, matching=False, seed=seed)[0].grid(),
                      walls)  # fmt: skip
    plain = score(mapped(walls, route, drift=True, matching=False, seed=seed)[0].grid(), walls)
    builder, added, truth = mapped(walls, route, drift=True, matching=True, seed=seed)
    matched = score(builder.grid(), walls)
    assert matched.near_05 >= bound.near_05
    assert matched.near_10 >= bound.near_10
    assert matched.seen >= bound.seen * truth_map.seen
    # Without matching the walls smear into fans: most occupied cells are off them.
    assert plain.near_10 <= 0.5
    assert matched.near_10 - plain.near_10 >= 0.4
    moved, turned = worst_error(added, truth)
    assert moved <= bound.moved_m and turned <= bound.turned_deg


def test_a_bare_corridor_is_matched_across_it_and_not_along() -> None:
    walls = long_corridor()
    builder, added, truth = mapped(walls, CORRIDOR_DRIVE, drift=True, matching=True)
    outcomes = Counter(a.outcome for a in added)
    middle = [a for a, t in zip(added, truth, strict=True) if 10 <= t.x <= 20]
    assert all(a.outcome is not MatchOutcome.MATCHED for a in middle)
    assert sum(a.matched for a in middle) >= 0.9 * len(middle)  # across it, at least
    assert outcomes[MatchOutcome.ACROSS_ONLY] >= len(middle)
    # Along it the odometry's 2 % is kept; across it and in heading the walls hold it.
    moved, turned = worst_error(added, truth)
    assert turned <= 1.5  # seeds 1-5: at worst 1.0 degrees
    assert max(abs(a.pose.y - t.y) for a, t in zip(added, truth, strict=True)) <= 0.05
    assert moved <= 0.02 * 56 + 0.05  # 56 m driven
    assert score(builder.grid(), walls).near_10 >= 0.85


def test_the_correction_carries_later_filter_poses_into_the_map() -> None:
    walls = care_home_wing()
    truth = drive(WING_DRIVE, RATE)
    poses = drifted(truth, 0.02, 1.5)
    builder = MapBuilder()
    for k, (pose, scan) in enumerate(zip(poses, sweeps(walls, truth, 360, 3), strict=True)):
        builder.add(pose, scan, k / RATE)
    raw = math.dist((poses[-1].x, poses[-1].y), (truth[-1].x, truth[-1].y))
    corrected = builder.correction.apply(poses[-1])
    assert raw > 2.0  # the drift is real
    assert math.dist((corrected.x, corrected.y), (truth[-1].x, truth[-1].y)) <= 0.1


def test_a_beam_that_meets_nothing_clears_only_so_far_and_hits_on_the_robot_are_dropped() -> None:
    bearing = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    empty = Sweep(12.0, tuple((math.inf, float(b)) for b in bearing))
    builder = MapBuilder()
    for stamp in range(4):  # four looks through a cell make it free
        assert builder.add(Pose(), empty, stamp).outcome is MatchOutcome.TOO_FEW_HITS
    on_robot = Sweep(12.0, tuple((0.1, float(b)) for b in bearing))
    builder.add(Pose(), on_robot, 4.0)
    grid = builder.grid()
    assert not (grid.cells == OCCUPIED).any()
    for reach, state in ((CLEAR_NO_HIT_M - 0.2, FREE), (CLEAR_NO_HIT_M + 0.3, UNKNOWN)):
        assert grid.cells[grid.cell_of(reach, 0.0)] == state
        assert grid.cells[grid.cell_of(0.0, -reach)] == state


def test_the_grid_grows_in_chunks_and_an_airport_fits() -> None:
    scan = Sweep(12.0, tuple((2.0, float(b)) for b in np.linspace(-3.1, 3.1, 360)))
    builder = MapBuilder(match_scans=False)
    builder.add(Pose(0, 0, 0), scan, 0.0)
    first = builder.view().cells.shape
    builder.add(Pose(1, 1, 0), scan, 1.0)
    assert builder.view().cells.shape == first  # within the chunk: no new allocation
    builder.add(Pose(300, 150, 0), scan, 2.0)  # the far corner of a 300 x 150 m airport
    view = builder.view()
    assert view.cells.shape[0] * view.resolution >= 150
    assert view.cells.shape[1] * view.resolution >= 300


def test_a_map_too_large_is_refused_and_left_as_it_was() -> None:
    scan = Sweep(12.0, tuple((2.0, float(b)) for b in np.linspace(-3.1, 3.1, 360)))
    builder = MapBuilder(match_scans=False)
    builder.add(Pose(0, 0, 0), scan, 0.0)
    before = builder.view()
    with pytest.raises(MapTooLarge, match="a map holds at most"):
        builder.add(Pose(400, 300, 0), scan, 1.0)
    assert builder.view() is before  # nothing drawn, nothing grown


@pytest.mark.parametrize(
    ("pose", "scan", "stamp", "message"),
    [
        (Pose(math.nan, 0, 0), Sweep(12.0, ((1.0, 0.0),)), 1.0, "finite"),
        (Pose(), Sweep(12.0, ((1.0, 0.0),)), -5.0, "older than the last"),
        (Pose(), Sweep(0.0, ((1.0, 0.0),)), 1.0, "range_max"),
        (Pose(), Sweep(12.0, ((1.0, math.inf),)), 1.0, "bearing"),
        (Pose(), Sweep(12.0, ((1.0, 0.0),) * (MAX_BEAMS + 1)), 1.0, "at most"),
    ],
    ids=["nan pose", "stamp backwards", "no range", "bad bearing", "too many beams"],
)
def test_a_scan_that_cannot_be_used_is_refused_clearly(
    pose: Pose, scan: Sweep, stamp: float, message: str
) -> None:
    builder = MapBuilder()
    builder.add(Pose(), Sweep(12.0, ((1.0, 0.0),)), 0.0)
    with pytest.raises(ValueError, match=message):
        builder.add(pose, scan, stamp)


def test_the_view_changes_only_with_a_scan_and_cannot_be_written() -> None:
    walls = furnished_room()
    truth = drive(ROOM_DRIVE, RATE)[:6]
    scans = sweeps(walls, truth, 360, 2)
    builder = MapBuilder()
    for k in range(5):
        builder.add(truth[k], scans[k], k / RATE)
    view = builder.view()
    assert builder.view() is view
    with pytest.raises(ValueError):
        view.cells[0, 0] = FREE
    builder.add(truth[5], scans[5], 5 / RATE)
    later = builder.view()
    assert later.revision == view.revision + 1
    grid = builder.grid()
    # The cropped grid is the view's cells where it lies.
    col = round((grid.origin[0] - later.origin[0]) / later.resolution)
    row = (
        later.cells.shape[0]
        - grid.shape[0]
        - round((grid.origin[1] - later.origin[1]) / later.resolution)
    )
    window = later.cells[row : row + grid.shape[0], col : col + grid.shape[1]]
    assert np.array_equal(window, grid.cells)
    assert (grid.cells == FREE).sum() > 1000 and (grid.cells == OCCUPIED).sum() > 100


def test_a_sensor_that_sees_ahead_only_clears_only_ahead() -> None:
    # 36 beams over 70 degrees, as the simulator's front range finder has them.
    ahead = Sweep(3.0, tuple((2.0, float(b)) for b in np.radians(np.linspace(-35, 35, 36))))
    builder = MapBuilder()
    for stamp in range(4):
        builder.add(Pose(), ahead, stamp)
    grid = builder.grid()
    assert grid.cells[grid.cell_of(1.0, 0.0)] == FREE
    for distance, bearing in ahead.beams:
        hit = (distance * math.cos(bearing), distance * math.sin(bearing))
        assert grid.cells[grid.cell_of(*hit)] == OCCUPIED
    assert grid.cells[grid.cell_of(0.0, 0.0)] == FREE  # the robot's own footprint
    view = builder.view()
    whole = OccupancyGrid(view.cells, view.resolution, view.origin)
    assert whole.cells[whole.cell_of(-1.0, 0.0)] == UNKNOWN
    assert whole.cells[whole.cell_of(0.0, 1.0)] == UNKNOWN


def test_a_wall_seen_along_its_face_keeps_its_doorway_its_own_width() -> None:
    """A hall below a room, the 0.15 m wall between them with a 0.8 m door, driven along
    on both sides at poses a few centimetres and a degree off the truth (a filter's
    error; matching off): the wall is seen edge-on from each end of the hall and room.
    Before the beams' ends were pulled back across their surface, those grazing beams
    cleared the wall's cells from both sides, and the doorway came out up to 1.35 m
    wide in these drives, three of six wider than the door (tests/teaching's flat: two
    rooms made one)."""
    door = [(2.0, DOOR_M)]
    between = wall(0, 1.5, 8, 1.5, door) + wall(0, 1.65, 8, 1.65, door)
    walls = np.array(box(0, 0, 8, 3.65) + between + [(2.0, 1.5, 2.0, 1.65),
                     (2.8, 1.5, 2.8, 1.65)], dtype=np.float64)  # fmt: skip
    truth = drive([(0.5, 0.75), (7.5, 0.75), (2.4, 0.75), (2.4, 2.6), (7.5, 2.6), (0.5, 2.6)],
                  RATE)  # fmt: skip
    seen = []
    for seed in range(1, 7):
        rng = np.random.default_rng(seed)
        builder = MapBuilder(match_scans=False)
        scans = sweeps(walls, truth, 360, seed)
        for k, (true, scan) in enumerate(zip(truth, scans, strict=True)):
            off = rng.normal(0.0, (0.03, 0.03, math.radians(1.0)))
            builder.add(Pose(true.x + off[0], true.y + off[1], true.heading + off[2]), scan,
                        k / RATE)  # fmt: skip
        grid = builder.grid()
        # The widest run of columns with no occupied cell in the wall's band.
        rows = slice(grid.cell_of(0.1, 1.75)[0], grid.cell_of(0.1, 1.4)[0] + 1)
        cols = slice(grid.cell_of(0.1, 1.5)[1], grid.cell_of(7.9, 1.5)[1])
        open_ = ~(grid.cells[rows, cols] == OCCUPIED).any(axis=0)
        runs = np.diff(np.flatnonzero(np.diff(np.concatenate([[0], open_, [0]]))))[::2]
        assert runs.max() <= round(DOOR_M / grid.resolution), seed
        seen.append(score(grid, np.array(between, dtype=np.float64)).seen)
    # The wall's faces within 0.10 m of an occupied cell: 0.87-1.00 of them in these
    # drives, 0.94 on average (before, 0.70-0.92, 0.79).
    assert np.mean(seen) >= 0.9, seen


def test_a_scan_whose_farthest_hits_glance_off_a_wall_is_drawn() -> None:
    """Seven beams meeting a wall 0.51 m away at 5-8 degrees, nothing else: each hit's
    end is pulled back 0.36 m along its beam, beyond the margin round the outline the
    drawing's window once took (an IndexError for some of these 20 placements)."""
    bearings = np.radians(np.arange(5.0, 8.01, 0.5))
    glancing = Sweep(12.0, tuple((0.51 / math.sin(b), float(b)) for b in bearings))
    for k in range(20):
        builder = MapBuilder(match_scans=False)
        at = Pose(0.0025 * k, 0.0013 + 0.0025 * k, 0.0)  # no hit on a cell's edge
        builder.add(at, glancing, 0.0)
        grid = builder.grid()
        for distance, bearing in glancing.beams:
            hit = (at.x + distance * math.cos(bearing), at.y + distance * math.sin(bearing))
            assert grid.cells[grid.cell_of(*hit)] == OCCUPIED


def test_a_wall_seen_well_outlasts_a_few_revolutions_and_a_thing_moved_away_goes():
    # The bound on a cell's log-odds is the map's memory. A trolley seen for 20
    # revolutions, then wheeled away: its cells are still an obstacle after 20
    # revolutions seeing through them (so a wall is not replaced by a few drawn at a
    # pose gone astray: at a bound of 400 it was, and the map followed the drift), and
    # no longer one after 24.
    room = box(0, 0, 6, 4)
    trolley = box(3.525, 1.825, 4.525, 2.325)  # its face mid-cell: every hit in one
    here = [Pose(1.5, 2.0, 0.0)] * 20
    builder = MapBuilder(match_scans=False)
    stamp = 0.0
    for sweep in sweeps(np.array(room + trolley, dtype=float), here, 360, 1):
        builder.add(here[0], sweep, stamp)
        stamp += 0.2

    def trolley_cells() -> np.ndarray:
        grid = builder.grid()
        rows, cols = np.nonzero(grid.cells == OCCUPIED)
        xs = grid.origin[0] + (cols + 0.5) * grid.resolution
        ys = grid.origin[1] + (grid.shape[0] - rows - 0.5) * grid.resolution
        return (xs > 3.4) & (xs < 4.6) & (ys > 1.7) & (ys < 2.4)

    seen = int(np.count_nonzero(trolley_cells()))
    assert seen >= 5
    gone = sweeps(np.array(room, dtype=float), here * 2, 360, 2)
    for sweep in gone[:20]:
        builder.add(here[0], sweep, stamp)
        stamp += 0.2
    assert np.count_nonzero(trolley_cells()) >= seen // 2
    for sweep in gone[20:24]:
        builder.add(here[0], sweep, stamp)
        stamp += 0.2
    assert not np.any(trolley_cells())
