"""The synthetic camera for an eye that only looks for markers: the picture drawn round
the markers that can be seen, and nowhere else (issue 25).

Without a screen (`go`, `patrol` with the simulator) nobody looks at the picture but
the console's marker eye (robot/marker_eye.py), and drawing all 800x600 pixels of it
ten times a second was two fifths of what a run at `--sim-speed inf` cost. So this camera,
which knows where the markers hang and where the robot truly stands, draws only a
window round each marker that could be in view, every pixel of it exactly as
`WorldCamera.render` draws it (`WorldCamera.draw` works any box out from its own rays),
and leaves the rest of the picture flat. The console still finds the markers in these
pixels, with the same detector, as it would in the whole picture: nothing but pixels
crosses to it.

A detector judges each pixel against those up to 11 pixels round it (OpenCV's largest
thresholding window is 23 pixels), and pixels as far outside a page as that decide
where its outline runs; so each window reaches twice that and a little more beyond its
marker's page (WINDOW_MARGIN_PX), and what a detector sees round a page is as the whole
picture has it. A marker is left out only where no detector could find it anyway: one
whose page would span under half a pixel a cell one way or the other (far off, or seen
nearly edge-on), or one that a wall hides across the middle and both sides of its
square (its outline cannot show whole).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import cv2
import numpy as np

from giraff_console.sim.camera import CAMERA_HEIGHT_M, MARKER_ON_WALL_M, Box, WorldCamera
from giraff_console.sim.camera_textures import COLOURS, WALL_PAINT
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import QUIET_ZONE_CELLS

# How far a window reaches beyond its page: see the module docstring (at 16 pixels a
# near marker's page outline came out otherwise than in the whole picture).
WINDOW_MARGIN_PX = 24
# What the picture shows outside the windows: the walls' paint, flat.
UNDRAWN = COLOURS[WALL_PAINT, 0]
# The least a cell of a page may span, in pixels, across or up, for its marker to be
# drawn: below it the cells alias into one another (see the module docstring).
SMALLEST_CELL_PX = 0.5
# A page corner nearer the camera's plane than this is cut off there: nothing so near
# shows in the picture unless it is within a centimetre of the lens.
NEAR_M = 0.01
# Where across a marker's square the rays that test whether a wall hides it run:
# its middle and near both its sides.
HIDDEN_SAMPLES = (-0.4, 0.0, 0.4)


class MarkerWindows:
    """Draws the markers' windows of the picture `camera` would render; see the module
    docstring. Thread-safe, as `camera` is."""

    def __init__(self, camera: WorldCamera, margin: int = WINDOW_MARGIN_PX) -> None:
        self.camera = camera
        self.margin = margin
        world = camera.world
        # Each marker's page, in cells across (its pattern and the quiet zone), and its
        # square's side, metres.
        self._page_cells = np.array([m.pattern.shape[0] + 2 * QUIET_ZONE_CELLS
                                     for m in world.markers], dtype=float)  # fmt: skip
        self._sizes = np.array([m.size for m in world.markers], dtype=float)

    def render(
        self, pose: TruePose, width: int, height: int,
        wanted: Sequence[tuple[int, int, int, int]] | None = None,
    ) -> np.ndarray:  # fmt: skip
        """A BGR image of `height` x `width` pixels: `camera.render`'s within the
        windows of `windows`, flat elsewhere. Given `wanted` boxes (left, top, right,
        bottom), only those are read out, as a sensor reads out the regions of interest
        asked of it: the rest of the picture is left black."""
        if wanted is None:
            image = _undrawn(width, height).copy()
        else:
            # Zeros cost nothing until written to; only the boxes are.
            image = np.zeros((height, width, 3), dtype=np.uint8)
            for left, top, right, bottom in wanted:
                image[max(top, 0) : bottom, max(left, 0) : right] = UNDRAWN
        for window in self.windows(pose, width, height, wanted):
            # A pixel more each way where the picture goes on: the lens's blur of the
            # window's edge takes in its neighbours (at the picture's own edges OpenCV
            # reflects, as it does for the whole picture).
            box = Box(width, height, max(window.left - 1, 0), max(window.top - 1, 0),
                      min(window.right + 1, width), min(window.bottom + 1, height))  # fmt: skip
            drawn = cv2.GaussianBlur(self.camera.draw(pose, box), (3, 3), 0)
            image[window.top : window.bottom, window.left : window.right] = drawn[
                window.top - box.top : window.bottom - box.top,
                window.left - box.left : window.right - box.left,
            ]
        return image

    def windows(
        self, pose: TruePose, width: int, height: int,
        wanted: Sequence[tuple[int, int, int, int]] | None = None,
    ) -> list[Box]:  # fmt: skip
        """The boxes of the picture to draw: round each marker that could be found in
        it (and reaches into one of the `wanted` boxes, if given), with the margin,
        those that overlap joined."""
        camera = self.camera
        world = camera.world
        candidates = camera.facing_the_camera(pose)
        # None farther than this spans half a pixel a cell even face on, at the edge of
        # the picture (where a thing looks 1 / cos^2 as wide as it would ahead).
        focal = camera.focal(width)
        widest = focal * (1 + (width / 2 / focal) ** 2)
        reach = np.hypot(*(world.marker_centre[candidates] - [pose.x, pose.y]).T)
        outer = world.marker_outer[candidates]
        cells = self._page_cells[candidates]
        candidates = candidates[reach <= widest * outer / (cells * SMALLEST_CELL_PX) + outer]
        if not len(candidates):
            return []
        matrix = camera.intrinsics(width, height).matrix()
        corners = _in_camera(self._page_corners(candidates), pose)  # (markers, 4, 3)
        # Pages wholly ahead of the camera, projected all at once.
        ahead = (corners[..., 2] >= NEAR_M).all(axis=1)
        projected = corners[ahead] @ matrix.T
        pixels = projected[..., :2] / projected[..., 2:]
        sides = np.linalg.norm(np.roll(pixels, -1, axis=1) - pixels, axis=2).min(axis=1)
        # Under half a pixel a cell one way (far off, or nearly edge-on): nothing to
        # decode. (OpenCV does decode a square seen edge-on at 0.9 pixels a cell.)
        big_enough = sides >= self._page_cells[candidates[ahead]] * SMALLEST_CELL_PX
        which = list(candidates[ahead][big_enough])
        lows, highs = list(pixels[big_enough].min(axis=1)), list(pixels[big_enough].max(axis=1))
        # Pages cut by the camera's plane: their part ahead of it, one by one (rare).
        for corner, cut in zip(corners[~ahead], candidates[~ahead], strict=True):
            clipped = _clipped(corner)
            if len(clipped) >= 3:
                projected = clipped @ matrix.T
                which.append(cut)
                lows.append((projected[:, :2] / projected[:, 2:]).min(axis=0))
                highs.append((projected[:, :2] / projected[:, 2:]).max(axis=0))
        if not which:
            return []
        low = np.maximum(np.floor(np.array(lows)).astype(int) - self.margin, 0)
        high = np.minimum(np.ceil(np.array(highs)).astype(int) + 1 + self.margin, [width, height])
        kept = (low < high).all(axis=1) & _reaching(low, high, wanted)
        if not kept.any():
            return []
        hidden = self._hidden(pose, np.array(which)[kept])
        return _joined([Box(width, height, *a, *b) for a, b, behind
                        in zip(low[kept].tolist(), high[kept].tolist(), hidden, strict=True)
                        if not behind])  # fmt: skip

    def _page_corners(self, which: np.ndarray) -> np.ndarray:
        """The four corners of each of the markers `which`'s pages (x, y, height), as the
        page is hung: top left, top right, bottom right, bottom left."""
        world = self.camera.world
        half = world.marker_outer[which] / 2
        right = np.zeros((len(which), 3))
        right[:, :2] = world.marker_right[which] * half[:, None]
        up = np.zeros((len(which), 3))
        up[:, 2] = half
        centre = np.column_stack([world.marker_centre[which], world.marker_height[which]])
        return centre[:, None, :] + np.stack([up - right, up + right, right - up, -right - up], 1)

    def _hidden(self, pose: TruePose, candidates: np.ndarray) -> np.ndarray:
        """Which of `candidates` a wall hides across the middle and near both sides of
        the square: by the rule the camera draws a page by (a column shows a page only
        where its wall is within MARKER_ON_WALL_M of the page's plane), none of its
        square is seen whole there."""
        world = self.camera.world
        across = np.array(HIDDEN_SAMPLES)[None, :, None]
        size = self._sizes[candidates][:, None, None]
        points = world.marker_centre[candidates][:, None, :] + (
            across * size * world.marker_right[candidates][:, None, :]
        )  # (markers, samples, 2)
        rel = points - [pose.x, pose.y]
        reach = np.hypot(rel[..., 0], rel[..., 1])
        dx, dy = (rel / np.maximum(reach, 1e-9)[..., None]).reshape(-1, 2).T
        walls = self.camera.wall_distance(pose, dx, dy).reshape(reach.shape)
        # How far off the page's plane the wall each ray meets stands.
        incidence = np.abs(np.einsum("msk,mk->ms", rel, world.marker_normal[candidates]))
        off = (reach - walls) * incidence / np.maximum(reach, 1e-9)
        return (off > MARKER_ON_WALL_M).all(axis=1)


@functools.cache
def _undrawn(width: int, height: int) -> np.ndarray:
    """A picture of nothing drawn, kept for each size: filling a picture pixel by pixel
    costs more than copying one whole."""
    image = np.empty((height, width, 3), dtype=np.uint8)
    image[:] = UNDRAWN
    image.setflags(write=False)
    return image


def _in_camera(points: np.ndarray, pose: TruePose) -> np.ndarray:
    """World points in the camera's axes: x to the right, y down, z ahead."""
    ahead = np.array([math.cos(pose.heading), math.sin(pose.heading), 0.0])
    axes = np.array([[ahead[1], -ahead[0], 0.0], [0.0, 0.0, -1.0], ahead])
    return (points - [pose.x, pose.y, CAMERA_HEIGHT_M]) @ axes.T


def _clipped(polygon: np.ndarray) -> np.ndarray:
    """The part of a polygon (camera axes) at least NEAR_M ahead of the camera."""
    ahead = polygon[:, 2] >= NEAR_M
    if ahead.all():
        return polygon
    kept = []
    for i, point in enumerate(polygon):
        following = polygon[(i + 1) % len(polygon)]
        if ahead[i]:
            kept.append(point)
        if ahead[i] != (following[2] >= NEAR_M):
            share = (NEAR_M - point[2]) / (following[2] - point[2])
            kept.append(point + share * (following - point))
    return np.array(kept).reshape(-1, 3)


def _reaching(low: np.ndarray, high: np.ndarray,
              wanted: Sequence[tuple[int, int, int, int]] | None) -> np.ndarray:  # fmt: skip
    """Which boxes (top left corners `low`, bottom right `high`, a row each) reach into
    any of the `wanted` boxes (all of them: None)."""
    if wanted is None:
        return np.ones(len(low), dtype=bool)
    reaching = np.zeros(len(low), dtype=bool)
    for left, top, right, bottom in wanted:
        reaching |= ((low[:, 0] < right) & (left < high[:, 0])
                     & (low[:, 1] < bottom) & (top < high[:, 1]))  # fmt: skip
    return reaching


def _joined(boxes: list[Box]) -> list[Box]:
    """`boxes`, those that overlap replaced by the box round both, until none overlap:
    each pixel is then drawn once."""
    boxes = list(boxes)
    joined = True
    while joined:
        joined = False
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                a, b = boxes[i], boxes[j]
                if a.left < b.right and b.left < a.right and a.top < b.bottom and b.top < a.bottom:
                    boxes[i] = Box(a.width, a.height, min(a.left, b.left), min(a.top, b.top),
                                   max(a.right, b.right), max(a.bottom, b.bottom))  # fmt: skip
                    del boxes[j]
                    joined = True
                    break
            if joined:
                break
    return boxes
