"""The synthetic camera's textures, where the geometry puts them (issue 14).

The camera looks its floor and walls up in textures (a homography of the floor's
tiles, a strip of heights per kind of wall column) and casts only against the walls in
view. These tests work each pixel out on its own instead, from the ray through it, and
check that the picture agrees wherever the answer is not within a fifth of a millimetre
of an edge.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.runtime.sim_site import plan_world
from giraff_console.sim.camera import CAMERA_HEIGHT_M, WorldCamera
from giraff_console.sim.camera_textures import (
    CEILING,
    FLOOR_TILE_M,
    FRAME,
    GROUT,
    PALETTE,
    PANEL_M,
    POSTER_DARK,
    POSTER_LIGHT,
    SEAM,
    SKIRTING,
    TILE_A,
    TILE_B,
    WALL_HEIGHT_M,
    WALL_PAINT,
)
from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import cast_rays
from giraff_console.sim.world import (
    DOOR_FRAME,
    POSTER_BOTTOM,
    POSTER_HEIGHT,
    POSTER_WIDTH,
    World,
    demo_world,
)

EXAMPLE = "giraff_console/floorplans/care-home.yaml"
# A point this near an edge of the textures could land on either side of it (the
# camera works in single precision); a texture half a millimetre off is caught.
SLACK_M = 0.0002
UNSURE = 255


def floor_material(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    odd = (np.floor(x / FLOOR_TILE_M) + np.floor(y / FLOOR_TILE_M)) % 2 == 1
    grout = (np.mod(x, FLOOR_TILE_M) < 0.02) | (np.mod(y, FLOOR_TILE_M) < 0.02)
    return np.where(grout, GROUT, np.where(odd, TILE_B, TILE_A))


def wall_material(u: np.ndarray, z: np.ndarray, poster_at: np.ndarray, frame: np.ndarray):
    """What a wall shows `u` metres along it and `z` up; NaN `poster_at` for no poster."""
    wall = np.where(np.mod(u, PANEL_M) < 0.03, SEAM, WALL_PAINT)
    wall = np.where(z < 0.12, SKIRTING, wall)
    pu, pv = u - poster_at, z - POSTER_BOTTOM
    on = (pu >= 0) & (pu <= POSTER_WIDTH) & (pv >= 0) & (pv <= POSTER_HEIGHT)
    dark = (np.floor(pu / 0.15) + np.floor(pv / 0.16)) % 2 == 0
    wall = np.where(on, np.where(dark, POSTER_DARK, POSTER_LIGHT), wall)
    wall = np.where(frame, FRAME, wall)
    return np.where((z >= 0) & (z <= WALL_HEIGHT_M), wall, np.where(z < 0, -1, CEILING))


def unless_near_an_edge(material, *coordinates):
    """`material(*coordinates)`, or UNSURE where moving any coordinate by SLACK_M
    changes it."""
    found = material(*coordinates)
    for k in range(len(coordinates)):
        for step in (-SLACK_M, SLACK_M):
            moved = list(coordinates)
            moved[k] = moved[k] + step
            found = np.where(material(*moved) == found, found, UNSURE)
    return found


def expected(world: World, pose: TruePose, width: int, height: int) -> np.ndarray:
    """Each pixel's material from its own ray, every wall cast against; UNSURE near an
    edge. (Rays that meet no wall, and the floor's rays behind the camera, give
    infinities and NaNs where they are not used.)"""
    with np.errstate(divide="ignore", invalid="ignore"):
        return _expected(world, pose, width, height)


def _expected(world: World, pose: TruePose, width: int, height: int) -> np.ndarray:
    focal = (width / 2) / math.tan(math.radians(90) / 2)
    left = (width / 2 - (np.arange(width) + 0.5)) / focal  # per metre ahead
    below = (np.arange(height) + 0.5 - height / 2)[:, None] / focal
    angle = pose.heading + np.arctan(left)
    t, s = cast_rays(pose.x, pose.y, np.cos(angle), np.sin(angle), world.start, world.end)
    hit = np.argmin(t, axis=1)
    columns = np.arange(width)
    depth = t[columns, hit] * np.cos(np.arctan(left))  # along the optical axis
    along = s[columns, hit] * world.length[hit]
    z = CAMERA_HEIGHT_M - below * depth
    frame = world.kind[hit] == DOOR_FRAME
    wall = unless_near_an_edge(
        lambda u, z: wall_material(u, z, world.poster_at[hit], frame), along, z
    )
    # Below the wall: the floor, where the ray through the pixel meets it.
    reach = CAMERA_HEIGHT_M / below  # metres ahead
    ahead, aside = np.cos(pose.heading), np.sin(pose.heading)
    x = pose.x + reach * (ahead - left * aside)
    y = pose.y + reach * (aside + left * ahead)
    floor = unless_near_an_edge(floor_material, x, y)
    return np.where(wall == -1, floor, wall)


def agrees(camera: WorldCamera, pose: TruePose, width: int, height: int) -> float:
    """The share of pixels sure of their material, with sure neighbours of the same
    (so that the lens's blur leaves them alone), that the picture shows in its colour;
    asserts that there are plenty of them."""
    truth = expected(camera.world, pose, width, height)
    image = camera.render(pose, width, height)
    padded = np.pad(truth, 1, mode="edge")
    same = np.ones(truth.shape, dtype=bool)
    for dy in range(3):
        for dx in range(3):
            same &= padded[dy : dy + height, dx : dx + width] == truth
    checked = same & (truth != UNSURE)
    assert checked.mean() > 0.8
    right = np.all(image == PALETTE[np.where(checked, truth, 0)], axis=2)
    return float(right[checked].mean())


@pytest.mark.parametrize(
    "pose",
    [
        TruePose(3.4, 0.0, math.radians(90)),  # the first room's north poster, square on
        TruePose(0.2, -1.3, math.radians(20)),  # through the doorway, its frames
        TruePose(7.5, 1.0, math.radians(-140)),  # from the second room, far walls
        TruePose(1.0, 2.5, math.radians(-60)),  # from by a wall, across the room
    ],
)
@pytest.mark.parametrize(("width", "height"), [(800, 600), (321, 239)])
def test_the_floor_and_walls_are_drawn_where_each_pixel_s_ray_meets_them(pose, width, height):
    assert agrees(WorldCamera(demo_world()), pose, width, height) == 1.0


def test_a_shifted_texture_would_be_caught():
    """The check above can fail: a camera whose floor is a tenth of a tile off."""
    camera = WorldCamera(demo_world())
    pose = TruePose(1.0, 2.5, math.radians(-60))
    shifted = TruePose(pose.x + 0.05, pose.y, pose.heading)
    moved = WorldCamera(demo_world())
    moved.render = lambda _pose, w, h: camera.render(shifted, w, h)
    assert agrees(moved, pose, 320, 240) < 0.99


def test_leaving_out_the_walls_out_of_view_changes_no_column():
    """Casting only against the walls that can be in view: every column of a building's
    views meets the same wall at the same distance as when cast against them all."""
    world = plan_world(load_floorplan(EXAMPLE))
    camera = WorldCamera(world)
    rng = np.random.default_rng(14)
    low, high = world.start.min(axis=0), world.start.max(axis=0)
    focal = camera.focal(400)
    offsets = np.arctan2(200 - (np.arange(400) + 0.5), focal)
    for _ in range(100):
        pose = TruePose(*rng.uniform(low, high), rng.uniform(-math.pi, math.pi))
        angles = pose.heading + offsets
        dx, dy = np.cos(angles), np.sin(angles)
        hit, distance, _ = camera._cast(pose, dx, dy)
        t, _ = cast_rays(pose.x, pose.y, dx, dy, world.start, world.end)
        nearest = t.min(axis=1)
        seen = nearest < 50.0
        assert np.array_equal(np.isfinite(distance), seen)
        assert np.array_equal(distance[seen], nearest[seen])
        assert np.array_equal(hit[seen], t.argmin(axis=1)[seen])
        assert len(camera._in_view(pose)) < len(world.walls)
