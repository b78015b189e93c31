"""Boxes and closed doors in the simulated building (§2.4), and how the camera shows them."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import Block, Door, Surroundings
from giraff_console.sim.world import demo_world

# The demo world's doorway between its two rooms: x = 6, 0.9 m wide, centred on y = 0.
DOORWAY = ((6.0, -0.45), (6.0, 0.45))


def test_blocks_are_numbered_and_placed_where_asked():
    things = Surroundings()
    first = things.block(1.0, 2.0)
    second = things.block(-1.0, 0.5, size=0.8)
    assert (first, second) == ("block-1", "block-2")
    assert things.blocks == {"block-1": Block(1.0, 2.0, 0.5), "block-2": Block(-1.0, 0.5, 0.8)}


def test_a_block_needs_a_positive_size():
    with pytest.raises(ValueError):
        Surroundings().block(0.0, 0.0, size=0.0)


def test_unblock_takes_away_the_block_under_the_point():
    things = Surroundings()
    things.block(1.0, 1.0)
    keep = things.block(3.0, 1.0)
    # 0.24 m from the centre of a 0.5 m box: still on it.
    assert things.unblock(1.24, 0.76) == ["block-1"]
    assert list(things.blocks) == [keep]


def test_unblock_takes_every_block_under_the_point():
    things = Surroundings()
    things.block(0.0, 0.0, size=1.0)
    things.block(0.3, 0.0, size=1.0)
    things.block(2.0, 0.0)
    assert things.unblock(0.2, 0.1) == ["block-1", "block-2"]
    assert list(things.blocks) == ["block-3"]


def test_unblock_beside_blocks_takes_only_the_nearest_within_half_a_metre():
    things = Surroundings()
    things.block(0.0, 0.0)  # its east edge at x = 0.25
    things.block(1.5, 0.0)  # its west edge at x = 1.25
    # 0.45 m from the first box's edge, 0.55 m from the second's.
    assert things.unblock(0.7, 0.0) == ["block-1"]
    assert list(things.blocks) == ["block-2"]


def test_unblock_far_from_every_block_takes_nothing():
    things = Surroundings()
    things.block(0.0, 0.0)
    revision = things.revision
    # 0.51 m beyond the edge at x = 0.25.
    assert things.unblock(0.76, 0.0) == []
    assert len(things.blocks) == 1
    assert things.revision == revision


def test_a_door_closed_then_opened():
    things = Surroundings()
    things.close_door("lab", *DOORWAY)
    assert things.doors == {"lab": Door(*DOORWAY)}
    assert things.open_door("lab") is True
    assert things.doors == {}
    assert things.segments()[0].shape == (0, 2)


def test_closing_a_closed_door_again_moves_it():
    things = Surroundings()
    things.close_door("lab", (0.0, 0.0), (0.9, 0.0))
    things.close_door("lab", (0.0, 1.0), (0.0, 1.9))
    starts, ends = things.segments()
    assert starts.tolist() == [[0.0, 1.0]] and ends.tolist() == [[0.0, 1.9]]


def test_opening_a_door_that_is_not_shut_does_nothing():
    things = Surroundings()
    things.block(0.0, 0.0)
    revision = things.revision
    assert things.open_door("lab") is False
    assert things.revision == revision


def test_segments_are_the_box_edges_and_the_doors():
    things = Surroundings()
    things.block(2.0, 1.0, size=0.4)
    things.close_door("lab", *DOORWAY)
    starts, ends = things.segments()
    assert starts.shape == ends.shape == (5, 2)
    # Each box edge runs from one corner to the next, the four making a closed square.
    assert np.array_equal(starts[1:4], ends[0:3]) and np.array_equal(starts[0], ends[3])
    assert sorted(map(tuple, starts[:4].tolist())) == [
        (1.8, 0.8),
        (1.8, 1.2),
        (2.2, 0.8),
        (2.2, 1.2),
    ]
    assert starts[4].tolist() == [6.0, -0.45] and ends[4].tolist() == [6.0, 0.45]


def test_the_segments_snapshot_is_reused_until_something_changes():
    things = Surroundings()
    things.block(0.0, 0.0)
    first = things.segments()
    again = things.segments()
    assert first[0] is again[0] and first[1] is again[1]
    things.block(1.0, 0.0)
    changed = things.segments()
    assert changed[0] is not first[0]
    assert len(first[0]) == 4 and len(changed[0]) == 8  # the old snapshot stays as it was


def test_every_change_moves_the_revision_on():
    things = Surroundings()
    revisions = [things.revision]
    things.block(0.0, 0.0)
    revisions.append(things.revision)
    things.close_door("lab", *DOORWAY)
    revisions.append(things.revision)
    things.open_door("lab")
    revisions.append(things.revision)
    things.unblock(0.0, 0.0)
    revisions.append(things.revision)
    assert revisions == [0, 1, 2, 3, 4]


def test_snapshots_cannot_be_changed_by_readers():
    things = Surroundings()
    things.block(0.0, 0.0)
    starts, _ = things.segments()
    with pytest.raises(ValueError):
        starts[0, 0] = 5.0
    with pytest.raises(TypeError):
        things.blocks["block-9"] = Block(0.0, 0.0, 1.0)  # type: ignore[index]


def test_touches_a_block_by_its_edge_and_its_corner():
    things = Surroundings()
    things.block(0.0, 0.0, size=1.0)  # edges at x, y = +-0.5
    assert things.touches(0.7, 0.0, radius=0.25)  # 0.2 m from the east edge
    assert not things.touches(0.8, 0.0, radius=0.25)  # 0.3 m from it
    corner_gap = math.hypot(0.2, 0.2)  # from (0.7, 0.7) to the corner (0.5, 0.5)
    assert things.touches(0.7, 0.7, radius=corner_gap + 0.01)
    assert not things.touches(0.7, 0.7, radius=corner_gap - 0.01)


def test_a_disc_inside_a_block_touches_it():
    things = Surroundings()
    things.block(0.0, 0.0, size=2.0)
    assert things.touches(0.1, 0.1, radius=0.2)


def test_touches_a_closed_door_but_not_an_open_one():
    things = Surroundings()
    things.close_door("lab", *DOORWAY)
    # The robot's middle 0.2 m short of the door, or past its jamb.
    assert things.touches(5.8, 0.0, radius=0.25)
    assert not things.touches(5.7, 0.0, radius=0.25)
    assert not things.touches(6.0, 0.75, radius=0.25)  # 0.3 m beyond the jamb at y = 0.45
    things.open_door("lab")
    assert not things.touches(5.8, 0.0, radius=0.25)


def test_changes_from_another_thread_never_tear_a_snapshot():
    things = Surroundings()
    done = threading.Event()

    def operator() -> None:
        for i in range(300):
            things.block(float(i), 0.0)
            things.close_door("lab", *DOORWAY)
            things.open_door("lab")
        done.set()

    worker = threading.Thread(target=operator)
    worker.start()
    while not done.is_set():
        snapshot = things.snapshot()
        assert len(snapshot.starts) == 4 * len(snapshot.blocks) + len(snapshot.doors)
    worker.join()
    assert len(things.blocks) == 300


# -- the camera ---------------------------------------------------------------------------

WORLD = demo_world()
FACING_THE_DOORWAY = TruePose(3.0, 0.0, 0.0)


def test_an_empty_surroundings_leaves_the_image_as_it_was():
    plain = WorldCamera(WORLD).render(FACING_THE_DOORWAY, 320, 240)
    empty = WorldCamera(WORLD, surroundings=Surroundings()).render(FACING_THE_DOORWAY, 320, 240)
    assert np.array_equal(plain, empty)


def test_a_block_in_view_changes_the_image_where_it_stands():
    things = Surroundings()
    camera = WorldCamera(WORLD, surroundings=things)
    plain = camera.render(FACING_THE_DOORWAY, 320, 240)
    things.block(4.5, 0.0, size=0.5)  # 1.25 m ahead, in the middle of the view
    boxed = camera.render(FACING_THE_DOORWAY, 320, 240)
    changed = np.any(plain != boxed, axis=2)
    columns = np.flatnonzero(changed.any(axis=0))
    # The box's face, 1.25 m ahead and 0.5 m wide, spans about 0.5 / 1.25 * focal
    # pixels around the centre (focal 160 px for 320 px over 90 degrees).
    focal = 160 / math.tan(math.radians(45))
    half_width = 0.25 / 1.25 * focal
    assert abs(columns.mean() - 160) < 2
    assert columns.min() == pytest.approx(160 - half_width, abs=3)
    assert columns.max() == pytest.approx(160 + half_width, abs=3)
    # Its top, 0.8 m up, is below the camera at 1.3 m: looking down on it, the middle
    # column sees its lid from its far edge (1.75 m away) down, then its face to the
    # bottom of the image; above the lid, the door behind it as before.
    lid_far_edge = 120 + (1.3 - 0.8) * focal / 1.75
    assert changed[math.ceil(lid_far_edge) + 1 :, 160].all()
    assert not changed[: math.floor(lid_far_edge) - 1, 160].any()


def test_a_block_behind_the_robot_does_not_show():
    things = Surroundings()
    things.block(1.5, 0.0)  # 1.5 m behind the camera
    camera = WorldCamera(WORLD, surroundings=things)
    assert np.array_equal(
        camera.render(FACING_THE_DOORWAY, 320, 240),
        WorldCamera(WORLD).render(FACING_THE_DOORWAY, 320, 240),
    )


def test_a_closed_door_fills_the_doorway_in_view():
    things = Surroundings()
    camera = WorldCamera(WORLD, surroundings=things)
    open_view = camera.render(FACING_THE_DOORWAY, 320, 240)
    things.close_door("lab", *DOORWAY)
    closed_view = camera.render(FACING_THE_DOORWAY, 320, 240)
    # Looking straight through the doorway: the far room's wall gives way to the door,
    # floor to ceiling, at the horizon and 1 m up.
    assert not np.array_equal(open_view[120, 160], closed_view[120, 160])
    assert not np.array_equal(open_view[60, 160], closed_view[60, 160])
    things.open_door("lab")
    assert np.array_equal(camera.render(FACING_THE_DOORWAY, 320, 240), open_view)


def test_a_block_in_a_closed_doorway_hides_only_the_foot_of_the_door():
    things = Surroundings()
    camera = WorldCamera(WORLD, surroundings=things)
    things.close_door("lab", *DOORWAY)
    door_only = camera.render(FACING_THE_DOORWAY, 320, 240)
    things.block(4.5, 0.0)
    both = camera.render(FACING_THE_DOORWAY, 320, 240)
    # Above the box's lid (its far edge 1.75 m away, 0.8 m up) the door still shows.
    lid_far_edge = 120 + (1.3 - 0.8) * 160 / 1.75
    above = slice(40, math.floor(lid_far_edge) - 1)
    assert np.array_equal(both[above, 160], door_only[above, 160])
    assert not np.array_equal(both[200, 160], door_only[200, 160])


def test_the_same_pose_and_surroundings_give_the_same_image():
    things = Surroundings()
    things.block(4.5, 0.3)
    things.close_door("lab", *DOORWAY)
    camera = WorldCamera(WORLD, surroundings=things)
    assert np.array_equal(
        camera.render(FACING_THE_DOORWAY, 320, 240), camera.render(FACING_THE_DOORWAY, 320, 240)
    )
