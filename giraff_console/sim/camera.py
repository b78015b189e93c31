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
camera's: nothing else tells the console where a marker is. Their pages are
supersampled as a sensor integrates light (sim/camera_pages.py). The camera is an ideal
pinhole whose intrinsics `intrinsics` gives.

Any box of the picture can be drawn alone (`draw`), each pixel exactly as the whole
picture has it, since each column and each pixel is worked out from its own ray: what
lets an eye that only looks for markers have just the boxes round them drawn
(sim/marker_windows.py, issue 25).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from giraff_console.sim.camera_pages import page_shades
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
from giraff_console.sim.world import DOOR_FRAME, POSTER_WIDTH, World

# The Giraff's camera is a wide-angle one in its head (§4.4).
FIELD_OF_VIEW_DEG = 90.0
# The mount: on the robot's centre line, above the middle of the wheel axle, looking
# level along the robot's heading (the head's tilt is not simulated).
CAMERA_HEIGHT_M = 1.3
MAX_RANGE_M = 50.0
# A chair or a trolley: lower than the camera, so that its lid shows.
BLOCK_HEIGHT_M = 0.8

# A marker is drawn where a column's wall lies within this of the marker's plane and
# runs along it (within 10 degrees): it hangs on that wall, not on one round a corner.
MARKER_ON_WALL_M = 0.10
MARKER_ALONG_WALL_COS = math.cos(math.radians(80))
# A box's wedge of rays is widened by this before walls outside it are left out, so that
# rounding never leaves out one a ray grazes.
WEDGE_SLACK_RAD = 1e-4


@dataclass(frozen=True)
class Box:
    """Part of a picture `width` x `height`: columns `left` to `right` and rows `top` to
    `bottom`, the ends excluded."""

    width: int
    height: int
    left: int
    top: int
    right: int
    bottom: int

    @classmethod
    def whole(cls, width: int, height: int) -> Box:
        return cls(width, height, 0, 0, width, height)

    def rows(self) -> np.ndarray:
        """The box's rows' centres, a column vector, as the picture numbers them."""
        return np.arange(self.top, self.bottom, dtype=np.float32)[:, None] + 0.5


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
        # A real lens never draws a perfectly sharp step; without this slight blur FAST
        # finds nothing on ideal corners.
        return cv2.GaussianBlur(self.draw(pose, Box.whole(width, height)), (3, 3), 0)

    def draw(self, pose: TruePose, box: Box) -> np.ndarray:
        """The BGR pixels of `box` (a pixel or more) of the picture from `pose`, before
        the lens's blur."""
        width, height = box.width, box.height
        focal = self.focal(width)
        horizon = height / 2
        offsets = np.arctan2(width / 2 - (np.arange(box.left, box.right) + 0.5), focal)
        offsets = offsets.astype(np.float32)
        angles = pose.heading + offsets
        dx, dy = np.cos(angles), np.sin(angles)
        # The box's rays span this wedge: only what stands in it is looked at.
        wedge = (float(offsets[-1]) - WEDGE_SLACK_RAD, float(offsets[0]) + WEDGE_SLACK_RAD)
        hit, distance, along = self._cast(pose, dx, dy, wedge)
        seen = np.isfinite(distance)
        # Where a column sees no wall its depth is never used; kept finite all the same.
        depth = np.where(seen, np.maximum(distance * np.cos(offsets), 1e-3), 1.0)
        depth = depth.astype(np.float32)
        # The ceiling above the horizon, the floor below it, the walls over both.
        first = math.ceil(horizon)
        material = np.empty((box.bottom - box.top, box.right - box.left), dtype=np.uint8)
        sky = min(max(first - box.top, 0), len(material))
        material[:sky] = CEILING
        if sky < len(material):
            material[sky:] = self._floor(pose, box, first, focal)
        self._walls(material, depth, hit, along, seen, focal, box)
        pages = self._markers(material, pose, dx, dy, distance, depth, hit, focal, box, wedge)
        if self.surroundings is not None:
            obstacles = self.surroundings.snapshot()
            if len(obstacles.kinds):
                self._obstacles(material, obstacles, pose, dx, dy, distance, offsets, focal, box)
        image = cv2.LUT(cv2.cvtColor(material, cv2.COLOR_GRAY2BGR), COLOURS)
        for rows, columns, grey in pages:
            # Where a box or a door now stands in front, it hides the page.
            shown = material[rows, columns] == MARKER_PAGE
            image[rows[shown], columns[shown]] = grey[shown, None]
        return image

    def _cast(self, pose: TruePose, dx: np.ndarray, dy: np.ndarray, wedge=None):
        """Nearest wall along each ray: its index, the distance, and how far along it.

        Only the walls that can be in view are cast against: a building has hundreds,
        and most lie wholly behind the camera or beyond an edge of its field of view
        (or of `wedge`, the directions from the heading, right to left, that the rays
        span, if given)."""
        world = self.world
        walls = self._in_view(pose) if wedge is None else self._in_view(pose, *wedge)
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

    def wall_distance(self, pose: TruePose, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """How far each ray from the camera along unit (`dx`, `dy`) runs before it meets
        a wall: inf if none within MAX_RANGE_M."""
        return self._cast(pose, dx, dy)[1]

    def _in_view(self, pose: TruePose, right: float | None = None,
                 left: float | None = None) -> np.ndarray:  # fmt: skip
        """The walls not wholly behind the camera nor wholly beyond one edge of its field
        of view (or of the narrower wedge from `right` to `left`, radians from the
        heading): no ray reaches the others. Some walls out of view are kept; none in
        view is dropped."""
        world = self.world
        if self.fov >= math.pi:
            return np.arange(len(world.walls))
        right = -self.fov / 2 if right is None else right
        left = self.fov / 2 if left is None else left
        return np.flatnonzero(~_outside(pose, world.start, world.end, right, left))

    def _walls(self, material, depth, hit, along, seen, focal, box) -> None:
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
        rows = _heights(depth, box, focal)
        rows *= np.float32(1 / WALL_STRIP_STEP_M)
        rows -= np.float32(0.5)
        columns = np.broadcast_to(strip, rows.shape).copy()
        cv2.remap(WALL_STRIPS, columns, rows, cv2.INTER_NEAREST, dst=material,
                  borderMode=cv2.BORDER_TRANSPARENT)  # fmt: skip

    def _markers(self, material, pose, dx, dy, distance, depth, hit, focal, box, wedge) -> list:
        """The markers' pages where their walls are the nearest thing a column sees.

        Returns, for each marker in view, its pixels (rows, columns of `box`) and their
        grey levels, and marks those pixels MARKER_PAGE so that obstacles can still hide
        them."""
        world = self.world
        seen = np.isfinite(distance)
        if not world.markers or not seen.any():
            return []
        camera = np.array([pose.x, pose.y])
        candidates = self.facing_the_camera(pose)
        # Those whose pages lie wholly outside the box's wedge have no column in it.
        half_page = world.marker_right[candidates] * world.marker_outer[candidates, None] / 2
        centre = world.marker_centre[candidates]
        candidates = candidates[~_outside(pose, centre - half_page, centre + half_page, *wedge)]
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
            z = _heights(depth[cols], box, focal)
            rows, which = np.nonzero(np.abs(z - marker.height) <= marker.outer / 2)
            if not len(rows):
                continue
            cols = cols[which]
            grey = page_shades(
                marker, np.array([pose.x, pose.y, CAMERA_HEIGHT_M]), pose.heading,
                rows + box.top, cols + box.left, self.intrinsics(box.width, box.height).matrix(),
            )  # fmt: skip
            material[rows, cols] = MARKER_PAGE
            pages.append((rows, cols, grey))
        return pages

    def facing_the_camera(self, pose: TruePose) -> np.ndarray:
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

    def _obstacles(
        self, material, obstacles: Obstacles, pose, dx, dy, wall_distance, offsets, focal, box
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
        below = box.rows() - box.height / 2
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

    def _floor(self, pose: TruePose, box: Box, first: int, focal: float):
        """The floor's tiles in `box`, from row `first` (the first below the horizon) of
        the picture down.

        The floor is a plane, so where each pixel's ray meets it is a homography of the
        pixel: column c, row r sees the floor CAMERA_HEIGHT_M * focal / (r + 0.5 -
        horizon) metres ahead of the camera, and (width / 2 - 0.5 - c) / focal times as
        far to its left. OpenCV warps the repeating texture with it."""
        width, height = box.width, box.height
        top = max(box.top, first)
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
        if box.left or top > first:
            # The box's pixel (0, 0) is the picture's (box.left, top).
            floor = floor @ [[1.0, 0.0, box.left], [0.0, 1.0, top - first], [0.0, 0.0, 1.0]]
        # Metres to texels, texel i's square from i to i + 1 (OpenCV rounds to the nearest).
        to_texels = np.array([[1 / FLOOR_TEXEL_M, 0.0, -0.5], [0.0, 1 / FLOOR_TEXEL_M, -0.5],
                              [0.0, 0.0, 1.0]])  # fmt: skip
        return cv2.warpPerspective(
            FLOOR_TEXTURE, to_texels @ floor, (box.right - box.left, box.bottom - top),
            flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP,
        )  # fmt: skip


def _outside(pose: TruePose, starts: np.ndarray, ends: np.ndarray, right: float,
             left: float) -> np.ndarray:  # fmt: skip
    """Which segments lie wholly behind the camera, or wholly beyond one edge of the wedge
    of directions from `right` to `left` (radians from the heading, less than a half
    turn apart): the half-planes through the camera that bound it."""
    heading = pose.heading
    middle = heading + (right + left) / 2
    mx, my = math.cos(middle), math.sin(middle)
    lx, ly = math.cos(heading + left), math.sin(heading + left)
    rx, ry = math.cos(heading + right), math.sin(heading + right)

    def tests(end: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x, y = end[:, 0] - pose.x, end[:, 1] - pose.y
        return x * mx + y * my < 0, lx * y - ly * x > 0, rx * y - ry * x < 0

    (behind, beyond_left, beyond_right), ended = tests(starts), tests(ends)
    return (behind & ended[0]) | (beyond_left & ended[1]) | (beyond_right & ended[2])


def _heights(depth: np.ndarray, box: Box, focal: float) -> np.ndarray:
    """The height above the floor that each pixel of the rows of `box` sees on a wall
    `depth` ahead of the camera, a column per depth."""
    return CAMERA_HEIGHT_M - (box.rows() - box.height / 2) * (depth[None, :] / focal)
