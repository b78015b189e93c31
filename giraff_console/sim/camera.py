"""What a camera on the simulated robot sees: a ray caster over the world's walls.

One ray per image column finds the nearest wall; the wall, the tiled floor and the
ceiling are then textured as a renderer does: panel seams and a skirting board on the
walls, dark door frames, chequered posters and floor tiles. The floor is a plane, so its
picture is a homography of its tiles; a wall seen by one column is a strip of heights,
the same for every column of its kind. Both are looked up with OpenCV's warps in the
textures of sim/camera_textures.py rather than worked out per pixel (issue 14 asks for
10 fps with markers beside other work, and a localisation benchmark of a hundred
thousand frames), and a given pose always gives the same image.

Given `Surroundings`, the camera also shows the boxes and closed doors that the range
finder senses, painted over the walls where they stand in front: the operator must see
why the robot stopped at a doorway (§2.4), not only a dot on the map.

Markers on the walls (issue 14) are drawn from their true cells, at their size, height
and facing, so that OpenCV's detector finds them in the pixels as it would in a real
camera's: nothing else tells the console where a marker is. A real sensor integrates
the light over each pixel; the markers are supersampled likewise, so their edges fall
between pixels where they should and a pose from their corners is as good as the
pixels allow. The camera is an ideal pinhole whose intrinsics `intrinsics` gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from giraff_console.sim.camera_textures import (
    BOX,
    BOX_LID,
    BOX_SIDE,
    CEILING,
    COLOURS,
    DOOR_LEAF,
    FLOOR_TEXEL_M,
    FLOOR_TEXTURE,
    FRAME_STRIP,
    MARKER_PAGE,
    PAINT_STRIP,
    PANEL_M,
    POSTER_CELL_WIDTH,
    SEAM_M,
    SEAM_STRIP,
    WALL_HEIGHT_M,
    WALL_STRIP_STEP_M,
    WALL_STRIPS,
)
from giraff_console.sim.drive import TruePose
from giraff_console.sim.surroundings import (
    BLOCK,
    CLOSED_DOOR,
    Obstacles,
    Surroundings,
    cast_rays,
)
from giraff_console.sim.world import DOOR_FRAME, POSTER_WIDTH, QUIET_ZONE_CELLS, World

# The Giraff's camera is a wide-angle one in its head (§4.4).
FIELD_OF_VIEW_DEG = 90.0
# The mount: on the robot's centre line, above the middle of the wheel axle, looking
# level along the robot's heading (the head's tilt is not simulated).
CAMERA_HEIGHT_M = 1.3
CAMERA_FORWARD_M = 0.0
MAX_RANGE_M = 50.0
# A chair or a trolley: lower than the camera, so that its lid shows.
BLOCK_HEIGHT_M = 0.8

# A marker's page in grey: its ink and its paper (PALETTE's MARKER_PAGE is a placeholder).
INK, PAPER = 25.0, 240.0
# A marker is drawn where a column's wall lies within this of the marker's plane and
# runs along it (within 10 degrees): it hangs on that wall, not on one round a corner.
MARKER_ON_WALL_M = 0.10
MARKER_ALONG_WALL_COS = math.cos(math.radians(80))
# Fine samples per cell side, 2 to MAX_FINE per pixel side: small cells get the most, so that
# an edge lands within a few hundredths of a pixel of where it should.
FINE_SAMPLES_PER_CELL = 32
MAX_FINE = 16


@dataclass(frozen=True)
class CameraIntrinsics:
    """A pinhole camera in OpenCV's terms: focal lengths and principal point in pixels
    (pixel centres at whole numbers), and the distortion coefficients (none here).

    The console's camera/markers.py has the same class: the simulator imports nothing of
    the console, so the two are kept field for field alike."""

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = ()

    def matrix(self) -> np.ndarray:
        return np.array(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64
        )


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

    def focal(self, width: int) -> float:
        """The focal length in pixels at `width`: the field of view spans the width."""
        return (width / 2) / math.tan(self.fov / 2)

    def intrinsics(self, width: int, height: int) -> CameraIntrinsics:
        """The camera's intrinsics at `width` x `height`, exactly as `render` projects.

        Column c's ray passes through x = c + 0.5 measured from the image's left edge,
        and the optical axis through width / 2; OpenCV puts pixel centres at whole
        numbers, hence the half pixel off the principal point."""
        focal = self.focal(width)
        return CameraIntrinsics(focal, focal, width / 2 - 0.5, height / 2 - 0.5)

    def render(self, pose: TruePose, width: int, height: int) -> np.ndarray:
        """A BGR image of `height` x `width` pixels."""
        focal = self.focal(width)
        horizon = height / 2
        offsets = np.arctan2(width / 2 - (np.arange(width) + 0.5), focal).astype(np.float32)
        angles = pose.heading + offsets
        dx, dy = np.cos(angles), np.sin(angles)
        hit, distance, along = self._cast(pose, dx, dy)
        seen = np.isfinite(distance)
        # Where a column sees no wall its depth is never used; kept finite all the same.
        depth = np.where(seen, np.maximum(distance * np.cos(offsets), 1e-3), 1.0)
        depth = depth.astype(np.float32)
        # The ceiling above the horizon, the floor below it, the walls over both.
        first = math.ceil(horizon)
        material = np.empty((height, width), dtype=np.uint8)
        material[:first] = CEILING
        material[first:] = self._floor(pose, width, height, first, focal)
        self._walls(material, depth, hit, along, seen, focal)
        pages = self._markers(material, pose, dx, dy, distance, depth, hit, focal)
        if self.surroundings is not None:
            obstacles = self.surroundings.snapshot()
            if len(obstacles.kinds):
                self._obstacles(
                    material, obstacles, pose, dx, dy, distance, offsets, horizon, focal
                )
        image = cv2.LUT(cv2.cvtColor(material, cv2.COLOR_GRAY2BGR), COLOURS)
        for rows, columns, grey in pages:
            # Where a box or a door now stands in front, it hides the page.
            shown = material[rows, columns] == MARKER_PAGE
            image[rows[shown], columns[shown]] = grey[shown, None]
        # A real lens never draws a perfectly sharp step; without this slight blur FAST
        # finds nothing on ideal corners.
        return cv2.GaussianBlur(image, (3, 3), 0)

    def _cast(self, pose: TruePose, dx: np.ndarray, dy: np.ndarray):
        """Nearest wall along each ray: its index, the distance, and how far along it.

        Only the walls that can be in view are cast against: a building has hundreds,
        and most lie wholly behind the camera or beyond an edge of its field of view."""
        world = self.world
        walls = self._in_view(pose)
        columns = np.arange(len(dx))
        if not len(walls):
            return np.zeros(len(dx), dtype=np.intp), np.full(len(dx), np.inf), np.zeros(len(dx))
        t, s = cast_rays(pose.x, pose.y, dx, dy, world.start[walls], world.end[walls])
        nearest = np.argmin(t, axis=1)
        hit = walls[nearest]
        distance = t[columns, nearest]
        distance = np.where(distance < MAX_RANGE_M, distance, np.inf)
        along = s[columns, nearest] * world.length[hit]
        return hit, distance, along

    def _in_view(self, pose: TruePose) -> np.ndarray:
        """The walls not wholly behind the camera nor wholly beyond one edge of its field
        of view (the half-planes through the camera that bound it): no ray reaches the
        others. Some walls out of view are kept; none in view is dropped."""
        world = self.world
        if self.fov >= math.pi:
            return np.arange(len(world.walls))
        ahead = np.array([math.cos(pose.heading), math.sin(pose.heading)])
        left = np.array([-ahead[1], ahead[0]])
        cos, sin = math.cos(self.fov / 2), math.sin(self.fov / 2)
        outside = []
        for end in (world.start, world.end):
            rel = end - [pose.x, pose.y]
            forward, aside = rel @ ahead, rel @ left
            outside.append(np.stack([forward < 0, aside * cos - forward * sin > 0,
                                     -aside * cos - forward * sin > 0]))  # fmt: skip
        return np.flatnonzero(~(outside[0] & outside[1]).any(axis=0))

    def _walls(self, material, depth, hit, along, seen, focal) -> None:
        """The walls, each column painted from its kind of strip (WALL_STRIPS): the height
        each pixel sees on the wall picks the strip's row. Pixels above or below the wall
        fall off the strip and keep the ceiling or the floor."""
        world = self.world
        if not len(world.walls):
            return  # an open floor (a plan of points and doors alone): nothing to paint
        u = along.astype(np.float32)
        seam = np.mod(u, PANEL_M) < SEAM_M
        poster_u = u - world.poster_at[hit].astype(np.float32)
        with np.errstate(invalid="ignore"):  # NaN where a wall has no poster
            on_poster = (poster_u >= 0) & (poster_u <= POSTER_WIDTH)
            odd = np.floor(poster_u / POSTER_CELL_WIDTH) % 2 == 1
        strip = np.where(seam, SEAM_STRIP, PAINT_STRIP) + on_poster * (1 + odd)
        strip = np.where(world.kind[hit] == DOOR_FRAME, FRAME_STRIP, strip)
        # No strip at all (off the table, so left alone) where a column sees no wall.
        strip = np.where(seen, strip, -1).astype(np.float32)
        # Row i of the strips from i to i + 1 millimetres: OpenCV takes the nearest row.
        rows = _heights(depth, material.shape[0], focal)
        rows *= np.float32(1 / WALL_STRIP_STEP_M)
        rows -= np.float32(0.5)
        columns = np.broadcast_to(strip, rows.shape).copy()
        cv2.remap(WALL_STRIPS, columns, rows, cv2.INTER_NEAREST, dst=material,
                  borderMode=cv2.BORDER_TRANSPARENT)  # fmt: skip

    def _markers(self, material, pose, dx, dy, distance, depth, hit, focal) -> list:
        """The markers' pages where their walls are the nearest thing a column sees.

        Returns, for each marker in view, its pixels (rows, columns) and their grey
        levels, and marks those pixels MARKER_PAGE so that obstacles can still hide
        them."""
        world = self.world
        seen = np.isfinite(distance)
        if not world.markers or not seen.any():
            return []
        camera = np.array([pose.x, pose.y])
        candidates = self._facing_the_camera(pose)
        if not len(candidates):
            return []
        columns = np.flatnonzero(seen)
        points = camera + distance[columns, None] * np.stack([dx[columns], dy[columns]], -1)
        centre = world.marker_centre[candidates]
        normal = world.marker_normal[candidates]
        rel = points[:, None, :] - centre[None, :, :]  # (columns, candidates, 2)
        off = np.einsum("cmk,mk->cm", rel, normal)
        across = np.einsum("cmk,mk->cm", rel, world.marker_right[candidates])
        parallel = np.abs(world.direction[hit[columns]] @ normal.T)
        on = (np.abs(off) <= MARKER_ON_WALL_M) & (parallel <= MARKER_ALONG_WALL_COS)
        on &= np.abs(across) <= world.marker_outer[candidates] / 2
        pages = []
        for which_candidate in np.flatnonzero(on.any(axis=0)):
            marker = world.markers[candidates[which_candidate]]
            cols = columns[on[:, which_candidate]]
            z = _heights(depth[cols], material.shape[0], focal)
            rows, which = np.nonzero(np.abs(z - marker.height) <= marker.outer / 2)
            if not len(rows):
                continue
            cols = cols[which]
            grey = self._page(marker, pose, rows, cols, material.shape, focal)
            material[rows, cols] = MARKER_PAGE
            pages.append((rows, cols, grey))
        return pages

    def _facing_the_camera(self, pose: TruePose) -> np.ndarray:
        """The markers that might be in view: their faces towards the camera (from the
        other side of its wall a marker is not there to see), within range and within
        the field of view give or take a page. Keeps the per-column work to a few of a
        building's hundreds."""
        world = self.world
        to_marker = world.marker_centre - [pose.x, pose.y]
        ahead = to_marker @ [math.cos(pose.heading), math.sin(pose.heading)]
        aside = to_marker @ [-math.sin(pose.heading), math.cos(pose.heading)]
        page = world.marker_outer
        front = np.einsum("mk,mk->m", to_marker, world.marker_normal) < 0
        near = np.hypot(ahead, aside) < MAX_RANGE_M
        in_view = np.abs(aside) <= (ahead + page) * math.tan(self.fov / 2) + page
        return np.flatnonzero(front & near & (ahead > -page) & in_view)

    def _page(self, marker, pose, rows, cols, shape, focal) -> np.ndarray:
        """The grey level of each of a marker's pixels: the page warped into the picture
        k times finer than its pixels, then averaged over each pixel, as a sensor would.

        The page is a plane, so the picture of it is a homography of its cells; OpenCV
        warps them, each fine sample taking the cell it falls in."""
        top, left = rows.min(), cols.min()
        height, width = rows.max() - top + 1, cols.max() - left + 1
        centre = np.array([marker.x, marker.y, marker.height])
        facing = marker.facing
        right = np.array([-math.sin(facing), math.cos(facing), 0.0])
        up = np.array([0.0, 0.0, 1.0])
        camera = np.array([pose.x, pose.y, CAMERA_HEIGHT_M])
        ahead = np.array([math.cos(pose.heading), math.sin(pose.heading), 0.0])
        # The camera's axes in the world: x to the right, y down, z ahead.
        axes = np.array([[ahead[1], -ahead[0], 0.0], [0.0, 0.0, -1.0], ahead])
        # Page metres (across to the right, up) to picture pixels.
        page_to_camera = np.column_stack([axes @ right, axes @ up, axes @ (centre - camera)])
        page_to_picture = self.intrinsics(shape[1], shape[0]).matrix() @ page_to_camera
        # Cells to sample: cell (i, j)'s centre at whole numbers, as OpenCV's remaps take
        # them; the page's quiet zone around the pattern.
        half, cell = marker.outer / 2, marker.cell
        cells_to_page = np.array([[cell, 0.0, cell / 2 - half], [0.0, -cell, half - cell / 2],
                                  [0.0, 0.0, 1.0]])  # fmt: skip
        # How many pixels a cell spans at the page's centre: the finer, the fewer samples.
        seen_from = camera - centre
        gap = float(seen_from[:2] @ [math.cos(facing), math.sin(facing)])
        cell_pixels = focal * cell * gap / max(float(seen_from @ seen_from), 1e-6)
        k = int(np.clip(math.ceil(FINE_SAMPLES_PER_CELL / max(cell_pixels, 1e-3)), 2, MAX_FINE))
        # Fine sample (i, j) of the box at pixel (left + (i + 0.5) / k - 0.5, ...).
        fine_to_picture = np.array(
            [[1 / k, 0.0, left + 0.5 / k - 0.5], [0.0, 1 / k, top + 0.5 / k - 0.5], [0, 0, 1.0]]
        )
        try:
            fine_to_cells = np.linalg.inv(page_to_picture @ cells_to_page) @ fine_to_picture
        except np.linalg.LinAlgError:  # seen exactly edge-on: no page to see
            return np.full(len(rows), PAPER, dtype=np.uint8)
        paper = np.pad(marker.pattern, QUIET_ZONE_CELLS, constant_values=True)
        shade = np.where(paper, np.float32(PAPER), np.float32(INK))
        fine = cv2.warpPerspective(
            shade, fine_to_cells, (width * k, height * k),
            flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT, borderValue=PAPER,
        )  # fmt: skip
        box = cv2.resize(fine, (width, height), interpolation=cv2.INTER_AREA)
        return np.round(box[rows - top, cols - left]).astype(np.uint8)

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

    def _floor(self, pose: TruePose, width: int, height: int, first: int, focal: float):
        """The floor's tiles from row `first` (the first below the horizon) down.

        The floor is a plane, so where each pixel's ray meets it is a homography of the
        pixel: column c, row r sees the floor CAMERA_HEIGHT_M * focal / (r + 0.5 -
        horizon) metres ahead of the camera, and (width / 2 - 0.5 - c) / focal times as
        far to its left. OpenCV warps the repeating texture with it."""
        ahead = np.array([math.cos(pose.heading), math.sin(pose.heading)])
        left = np.array([-ahead[1], ahead[0]])
        camera = np.array([pose.x, pose.y])
        # Homogeneous in (c, r - first, 1); the last row is r + 0.5 - horizon.
        below = first + 0.5 - height / 2
        floor = np.zeros((3, 3))
        floor[:2, 0] = -CAMERA_HEIGHT_M * left
        floor[:2, 1] = camera
        floor[:2, 2] = CAMERA_HEIGHT_M * (focal * ahead + (width / 2 - 0.5) * left)
        floor[:2, 2] += camera * below
        floor[2] = [0.0, 1.0, below]
        # Metres to texels, texel i's square from i to i + 1 (OpenCV rounds to the nearest).
        to_texels = np.array([[1 / FLOOR_TEXEL_M, 0.0, -0.5], [0.0, 1 / FLOOR_TEXEL_M, -0.5],
                              [0.0, 0.0, 1.0]])  # fmt: skip
        return cv2.warpPerspective(
            FLOOR_TEXTURE, to_texels @ floor, (width, height - first),
            flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP,
        )  # fmt: skip


def _heights(depth: np.ndarray, height: int, focal: float) -> np.ndarray:
    """The height above the floor that each pixel of a picture `height` rows high sees
    on a wall `depth` ahead of the camera, a column per depth."""
    rows = np.arange(height, dtype=np.float32)[:, None] + 0.5
    return CAMERA_HEIGHT_M - (rows - height / 2) * (depth[None, :] / focal)
