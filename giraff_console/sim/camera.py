"""What a camera on the simulated robot sees: a ray caster over the world's walls.

One ray per image column finds the nearest wall; the wall, the tiled floor and the
ceiling are then shaded per pixel with procedural textures: panel seams and a skirting
board on the walls, dark door frames, chequered posters and floor tiles. All of it is
vectorised with numpy, and a given pose always gives the same image.

Given `Surroundings`, the camera also shows the boxes and closed doors that the range
finder senses, painted over the walls where they stand in front: the operator must see
why the robot stopped at a doorway (§2.4), not only a dot on the map.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import (
    BLOCK,
    CLOSED_DOOR,
    Obstacles,
    Surroundings,
    cast_rays,
)
from giraff_console.sim.world import (
    DOOR_FRAME,
    POSTER_BOTTOM,
    POSTER_HEIGHT,
    POSTER_WIDTH,
    World,
)

# The Giraff's camera is a wide-angle one in its head (§4.4).
FIELD_OF_VIEW_DEG = 90.0
CAMERA_HEIGHT_M = 1.3
WALL_HEIGHT_M = 2.5
FLOOR_TILE_M = 0.5
PANEL_M = 1.2
MAX_RANGE_M = 50.0
# A chair or a trolley: lower than the camera, so that its lid shows.
BLOCK_HEIGHT_M = 0.8

# Materials, and their colours in BGR as OpenCV keeps them.
CEILING, WALL_PAINT, SEAM, SKIRTING, FRAME, POSTER_DARK, POSTER_LIGHT, TILE_A, TILE_B, GROUT = (
    range(10)
)
# Obstacles: an orange box, its faces shaded by which way they face, and a door leaf a
# shade lighter than its frame so the frame still shows around it.
BOX, BOX_SIDE, BOX_LID, DOOR_LEAF = range(10, 14)
PALETTE = np.array(
    [
        [225, 225, 220], [178, 196, 214], [110, 120, 130], [60, 70, 90], [40, 55, 85],
        [40, 30, 150], [235, 235, 235], [150, 150, 140], [120, 118, 110], [70, 70, 70],
        [30, 140, 235], [20, 105, 185], [90, 180, 250], [45, 70, 105],
    ],
    dtype=np.uint8,
)  # fmt: skip


class WorldCamera:
    """Renders the world from a pose; thread-safe, since it keeps no state per frame."""

    def __init__(
        self,
        world: World,
        fov_deg: float = FIELD_OF_VIEW_DEG,
        surroundings: Surroundings | None = None,
    ) -> None:
        self.world = world
        self.fov = math.radians(fov_deg)
        self.surroundings = surroundings

    def render(self, pose: TruePose, width: int, height: int) -> np.ndarray:
        """A BGR image of `height` x `width` pixels."""
        focal = (width / 2) / math.tan(self.fov / 2)
        horizon = height / 2
        offsets = np.arctan2(width / 2 - (np.arange(width) + 0.5), focal).astype(np.float32)
        angles = pose.heading + offsets
        dx, dy = np.cos(angles), np.sin(angles)
        hit, distance, along = self._cast(pose.x, pose.y, dx, dy)
        depth = np.maximum(distance * np.cos(offsets), 1e-3).astype(np.float32)
        rows = np.arange(height, dtype=np.float32)[:, None] + 0.5
        # The height above the floor that each pixel would see on its column's wall.
        z = CAMERA_HEIGHT_M - (rows - horizon) * (depth[None, :] / focal)
        material = np.full((height, width), CEILING, dtype=np.uint8)
        self._floor(material, z, pose, angles, offsets, horizon, focal)
        self._walls(material, z, hit, along, np.isfinite(distance))
        if self.surroundings is not None:
            obstacles = self.surroundings.snapshot()
            if len(obstacles.kinds):
                self._obstacles(
                    material, obstacles, pose, dx, dy, distance, offsets, horizon, focal
                )
        # A real lens never draws a perfectly sharp step; without this slight blur FAST
        # finds nothing on ideal corners.
        return cv2.GaussianBlur(PALETTE[material], (3, 3), 0)

    def _cast(self, x: float, y: float, dx: np.ndarray, dy: np.ndarray):
        """Nearest wall along each ray: its index, the distance, and how far along it."""
        world = self.world
        t, s = cast_rays(x, y, dx, dy, world.start, world.end)
        hit = np.argmin(t, axis=1)
        columns = np.arange(len(dx))
        distance = t[columns, hit]
        distance = np.where(distance < MAX_RANGE_M, distance, np.inf)
        along = s[columns, hit] * world.length[hit]
        return hit, distance, along

    def _walls(self, material, z, hit, along, seen) -> None:
        world = self.world
        on_wall = (z >= 0) & (z <= WALL_HEIGHT_M) & seen[None, :]
        u = np.broadcast_to(along.astype(np.float32)[None, :], z.shape)
        wall = np.where(np.mod(u, PANEL_M) < 0.03, SEAM, WALL_PAINT).astype(np.uint8)
        wall[z < 0.12] = SKIRTING
        poster_u = u - world.poster_at[hit].astype(np.float32)[None, :]
        poster_v = z - POSTER_BOTTOM
        in_poster = (poster_u >= 0) & (poster_u <= POSTER_WIDTH)
        in_poster &= (poster_v >= 0) & (poster_v <= POSTER_HEIGHT)
        with np.errstate(invalid="ignore"):  # NaN where a wall has no poster
            dark = (np.floor(poster_u / 0.15) + np.floor(poster_v / 0.16)) % 2 == 0
        wall[in_poster & dark] = POSTER_DARK
        wall[in_poster & ~dark] = POSTER_LIGHT
        wall[:, world.kind[hit] == DOOR_FRAME] = FRAME
        material[on_wall] = wall[on_wall]

    def _obstacles(
        self, material, obstacles: Obstacles, pose, dx, dy, wall_distance, offsets, horizon, focal
    ) -> None:
        """Boxes and closed doors, over the walls and the floor where they stand nearer.

        A door fills its doorway to the ceiling, as the walls do. A box is lower than the
        camera, so above its front face shows its lid, as far back as the ray leaves the
        box; above that, whatever stands behind it. So each column paints the things it
        crosses from the farthest to the nearest: a box in front of a closed door hides
        only the lower part of the door."""
        t, _ = cast_rays(pose.x, pose.y, dx, dy, obstacles.starts, obstacles.ends)
        # Segments come grouped by the box or door they belong to (`Obstacles`).
        firsts = np.flatnonzero(np.diff(obstacles.owners, prepend=-1))
        meet = np.minimum.reduceat(t, firsts, axis=1)  # (columns, things)
        crossed = (meet < wall_distance[:, None]) & (meet < MAX_RANGE_M)
        layers = crossed.sum(axis=1)
        if not layers.any():
            return
        leave = np.maximum.reduceat(np.where(np.isfinite(t), t, -np.inf), firsts, axis=1)
        edge = obstacles.ends - obstacles.starts
        # Which face a ray meets: light falls differently on faces along x and along y.
        along_x = np.abs(edge[:, 0]) >= np.abs(edge[:, 1])
        met = t == meet[:, obstacles.owners]
        meets_x = np.maximum.reduceat(met & along_x, firsts, axis=1)
        nearest_first = np.argsort(meet, axis=1, kind="stable")
        kind = obstacles.kinds[firsts]
        below = np.arange(material.shape[0], dtype=np.float32)[:, None] + 0.5 - horizon
        cos = np.cos(offsets)

        def z_at(distance: np.ndarray, columns: np.ndarray) -> np.ndarray:
            """The height each pixel of `columns` sees at `distance` along its ray, as for
            the walls in `render`."""
            depth = np.maximum(distance * cos[columns], 1e-3).astype(np.float32)
            return CAMERA_HEIGHT_M - below * (depth[None, :] / focal)

        for layer in range(layers.max() - 1, -1, -1):
            columns = np.flatnonzero(layers > layer)
            thing = nearest_first[columns, layer]
            is_box = kind[thing] == BLOCK
            top = np.where(is_box, BLOCK_HEIGHT_M, WALL_HEIGHT_M).astype(np.float32)
            z_near = z_at(meet[columns, thing], columns)
            # A wall through a box cuts its lid short.
            z_far = z_at(np.minimum(leave[columns, thing], wall_distance[columns]), columns)
            face = (z_near >= 0) & (z_near <= top)
            lid = is_box & (z_near > top) & (z_far <= top)
            box = np.where(meets_x[columns, thing], BOX, BOX_SIDE)
            paint = np.where(kind[thing] == CLOSED_DOOR, DOOR_LEAF, box).astype(np.uint8)
            painted = np.where(face, paint[None, :], material[:, columns])
            material[:, columns] = np.where(lid, np.uint8(BOX_LID), painted)

    def _floor(self, material, z, pose, angles, offsets, horizon, focal) -> None:
        """Floor tiles below the walls, found by following each pixel's ray to the floor."""
        first = math.ceil(horizon)
        lower = z[first:] < 0
        rows = np.arange(first, material.shape[0], dtype=np.float32)[:, None] + 0.5
        reach = (CAMERA_HEIGHT_M * focal / (rows - horizon)) / np.cos(offsets)[None, :]
        fx = pose.x + reach * np.cos(angles).astype(np.float32)[None, :]
        fy = pose.y + reach * np.sin(angles).astype(np.float32)[None, :]
        tile = np.where(
            (np.floor(fx / FLOOR_TILE_M) + np.floor(fy / FLOOR_TILE_M)) % 2 == 0, TILE_A, TILE_B
        )
        grout = (np.mod(fx, FLOOR_TILE_M) < 0.02) | (np.mod(fy, FLOOR_TILE_M) < 0.02)
        tile = np.where(grout, GROUT, tile).astype(np.uint8)
        material[first:][lower] = tile[lower]
