"""What a camera on the simulated robot sees: a ray caster over the world's walls.

One ray per image column finds the nearest wall; the wall, the tiled floor and the
ceiling are then shaded per pixel with procedural textures: panel seams and a skirting
board on the walls, dark door frames, chequered posters and floor tiles. All of it is
vectorised with numpy, and a given pose always gives the same image.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.sim.drive import TruePose
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

# Materials, and their colours in BGR as OpenCV keeps them.
CEILING, WALL_PAINT, SEAM, SKIRTING, FRAME, POSTER_DARK, POSTER_LIGHT, TILE_A, TILE_B, GROUT = (
    range(10)
)
PALETTE = np.array(
    [
        [225, 225, 220], [178, 196, 214], [110, 120, 130], [60, 70, 90], [40, 55, 85],
        [40, 30, 150], [235, 235, 235], [150, 150, 140], [120, 118, 110], [70, 70, 70],
    ],
    dtype=np.uint8,
)  # fmt: skip


class WorldCamera:
    """Renders the world from a pose; thread-safe, since it keeps no state per frame."""

    def __init__(self, world: World, fov_deg: float = FIELD_OF_VIEW_DEG) -> None:
        self.world = world
        self.fov = math.radians(fov_deg)

    def render(self, pose: TruePose, width: int, height: int) -> np.ndarray:
        """A BGR image of `height` x `width` pixels."""
        focal = (width / 2) / math.tan(self.fov / 2)
        horizon = height / 2
        offsets = np.arctan2(width / 2 - (np.arange(width) + 0.5), focal).astype(np.float32)
        angles = pose.heading + offsets
        hit, distance, along = self._cast(pose.x, pose.y, np.cos(angles), np.sin(angles))
        depth = np.maximum(distance * np.cos(offsets), 1e-3).astype(np.float32)
        rows = np.arange(height, dtype=np.float32)[:, None] + 0.5
        # The height above the floor that each pixel would see on its column's wall.
        z = CAMERA_HEIGHT_M - (rows - horizon) * (depth[None, :] / focal)
        material = np.full((height, width), CEILING, dtype=np.uint8)
        self._floor(material, z, pose, angles, offsets, horizon, focal)
        self._walls(material, z, hit, along, np.isfinite(distance))
        # A real lens never draws a perfectly sharp step; without this slight blur FAST
        # finds nothing on ideal corners.
        return cv2.GaussianBlur(PALETTE[material], (3, 3), 0)

    def _cast(self, x: float, y: float, dx: np.ndarray, dy: np.ndarray):
        """Nearest wall along each ray: its index, the distance, and how far along it."""
        world = self.world
        edge = world.end - world.start  # (walls, 2)
        rel = world.start - np.array([x, y])  # (walls, 2)
        denom = dx[:, None] * edge[None, :, 1] - dy[:, None] * edge[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (rel[None, :, 0] * edge[None, :, 1] - rel[None, :, 1] * edge[None, :, 0]) / denom
            s = (rel[None, :, 0] * dy[:, None] - rel[None, :, 1] * dx[:, None]) / denom
        valid = (np.abs(denom) > 1e-12) & (t > 1e-6) & (s >= 0) & (s <= 1)
        t = np.where(valid, t, np.inf)
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
