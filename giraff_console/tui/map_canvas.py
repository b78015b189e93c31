"""The floor plan, the robot and its plan drawn in Braille, for the console's map view.

A Braille character holds 2 x 4 dots, and a terminal cell is about twice as tall as it is
wide, so the dots are square: the map keeps its shape at any zoom and a character shows
eight times as much as the half-block camera picture. A dot is a square of the map
`metres_per_dot` on a side; map y grows upwards, screen rows downwards.

It is pure and vectorised, as the view is redrawn at up to 20 Hz while the robot moves:
the grid is max-pooled into dots, the shapes drawn with cv2 into a mask a layer, and the
masks packed into characters styled in runs. Layers, highest first: robot, markers
rejected and seen lately, the robot's uncertainty ellipse, planned path, obstacles,
doors, the plan's markers, walls, unknown space. A character shows the dots of all of them
in the colour of the highest; room labels replace the dots where they fit.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from functools import cache

import cv2
import numpy as np
from rich.style import Style
from rich.text import Span, Text

from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.tui.map_scene import DoorMark, MapScene, Point

MIN_METRES_PER_DOT = 0.02  # a 0.1 m wall five dots thick: closer shows nothing more
MAX_METRES_PER_DOT = 2.0  # a 100 m building in 25 characters
OBSTACLE_RADIUS_M = 0.05
# A marker is drawn as a spot about the size of a printed one (the example's are 0.16 m),
# just in front of its wall, so that the markers either side of a wall stay apart.
MARKER_RADIUS_M = 0.08
# The uncertainty ellipse is drawn at two standard deviations, which hold the robot 86%
# of the time (a two-dimensional normal); one would hold it only 39% of the time.
ELLIPSE_SIGMAS = 2.0
# Fractional dot coordinates for cv2's drawing functions: 3 bits place a shape to 1/8 dot,
# so that a path does not jitter by a whole dot as the view pans.
_SHIFT = 3
_ONE = 1 << _SHIFT

# Layers, in rising priority; each character is styled by the highest one it has dots of.
# The plan's markers hang beside doorways, so zoomed out they share characters with
# the doors: they go under them, so that a door still shows whether it is shut.
(BLANK, UNSEEN, WALL, MARKER, DOOR_OPEN, DOOR_CLOSED, OBSTACLE, PATH, ELLIPSE, MARKER_SEEN,
 MARKER_REJECTED, ROBOT, LABEL) = range(13)  # fmt: skip

# Each layer's colour as a name, which 256- and 16-colour terminals show well, and in
# finer RGB for truecolor ones.
_COLOURS = {
    UNSEEN: ("grey35", "rgb(78,78,78)"),
    WALL: ("grey82", "rgb(214,214,214)"),
    DOOR_OPEN: ("green3", "rgb(60,210,90)"),
    DOOR_CLOSED: ("red3", "rgb(215,40,40)"),
    # The markers are purple, bright once seen, orange when the filter's gate turned one
    # down (a marker moved on the wall, or a misread): colours nothing else uses.
    MARKER: ("medium_purple3", "rgb(140,100,200)"),
    OBSTACLE: ("red1", "rgb(255,70,70)"),
    PATH: ("cyan1", "rgb(0,215,255)"),
    ELLIPSE: ("gold3", "rgb(215,175,0)"),  # the robot's, so a darker shade of its yellow
    MARKER_SEEN: ("magenta1", "rgb(255,80,255)"),
    MARKER_REJECTED: ("dark_orange", "rgb(255,130,0)"),
    ROBOT: ("yellow1", "rgb(255,230,40)"),
}
_BOLD = (MARKER_SEEN, MARKER_REJECTED, ROBOT)


@cache
def layer_styles(truecolor: bool) -> dict[int, Style | None]:
    """The style of every layer, for rendering and for tests that check colours."""
    styles: dict[int, Style | None] = {
        layer: Style(color=colours[truecolor], bold=layer in _BOLD)
        for layer, colours in _COLOURS.items()
    }
    return styles | {BLANK: None, LABEL: Style(dim=True)}


@dataclass(frozen=True)
class Viewport:
    """The part of the map on screen: its centre and the size of a dot."""

    centre: Point
    metres_per_dot: float

    def zoomed(self, factor: float, about: Point | None = None) -> Viewport:
        """Closer by `factor` (> 1 zooms in), clamped, keeping `about` where it is on screen."""
        scale = _clamp(self.metres_per_dot / factor)
        if about is None:
            return replace(self, metres_per_dot=scale)
        ratio = scale / self.metres_per_dot
        cx, cy = self.centre
        ax, ay = about
        return Viewport((ax + (cx - ax) * ratio, ay + (cy - ay) * ratio), scale)

    def panned(self, dx_chars: float, dy_chars: float) -> Viewport:
        """The view moved `dx_chars` characters right and `dy_chars` down the screen."""
        (x, y), step = self.centre, self.metres_per_dot
        return replace(self, centre=(x + 2 * dx_chars * step, y - 4 * dy_chars * step))

    def corner(self, cols: int, rows: int) -> Point:
        """The map (x, y) of the top-left corner of a view `cols` x `rows` characters."""
        x, y = self.centre
        return x - cols * self.metres_per_dot, y + 2 * rows * self.metres_per_dot

    def char_of(self, x: float, y: float, cols: int, rows: int) -> tuple[int, int]:
        """The (column, row) of the character showing map point (x, y); may be off screen."""
        left, top = self.corner(cols, rows)
        step = self.metres_per_dot
        return math.floor((x - left) / (2 * step)), math.floor((top - y) / (4 * step))

    def point_at(self, col: float, row: float, cols: int, rows: int) -> Point:
        """The map (x, y) at the middle of character (col, row)."""
        left, top = self.corner(cols, rows)
        step = self.metres_per_dot
        return left + (col + 0.5) * 2 * step, top - (row + 0.5) * 4 * step


def _clamp(metres_per_dot: float) -> float:
    return min(MAX_METRES_PER_DOT, max(MIN_METRES_PER_DOT, metres_per_dot))


def fit_grid(grid: OccupancyGrid, cols: int, rows: int) -> Viewport:
    """A viewport showing the whole grid in `cols` x `rows` characters, centred."""
    height, width = (n * grid.resolution for n in grid.shape)
    centre = (grid.origin[0] + width / 2, grid.origin[1] + height / 2)
    return Viewport(centre, _clamp(max(width / (2 * max(1, cols)), height / (4 * max(1, rows)))))


# The bit of each dot of a Braille character, by (dot row, dot column): Unicode numbers
# the left column's first three dots, then the right column's, then the bottom row.
_BITS = ((0, 3), (1, 4), (2, 5), (6, 7))
# Cells ranked so that max pooling keeps a wall over floor, and floor over unknown;
# 0 is left for dots off the grid.
_UNKNOWN, _FLOOR, _WALL = 1, 2, 3
_RANK = np.zeros(256, dtype=np.uint8)
_RANK[UNKNOWN], _RANK[FREE], _RANK[OCCUPIED] = _UNKNOWN, _FLOOR, _WALL
# Layer BLANK is never drawn; its slot in the stack of masks holds the floor instead, so
# that one packing finds both the dots and the characters that are all floor.
_FLOOR_SLOT = BLANK


def render_map(scene: MapScene, viewport: Viewport, cols: int, rows: int, truecolor: bool) -> Text:
    """The scene as `rows` lines of exactly `cols` characters."""
    if cols <= 0 or rows <= 0:  # a squeezed widget; cv2 cannot draw on empty images
        return Text("\n" * (rows - 1), end="")
    frame = _Frame(viewport, cols, rows)
    rank = _pool(scene.walls, viewport, cols, rows)
    masks = np.zeros((ROBOT + 1, *frame.shape), np.uint8)
    masks[_FLOOR_SLOT] = rank == _FLOOR
    # Unknown space gets one dot in every other character: enough to tell the inside of
    # the building from the outside, sparse enough not to compete with the walls.
    masks[UNSEEN, 1::8, 0::4] = rank[1::8, 0::4] == _UNKNOWN
    masks[UNSEEN, 5::8, 2::4] = rank[5::8, 2::4] == _UNKNOWN
    masks[WALL] = rank == _WALL
    _draw_doors(scene.doors, frame, masks)
    _draw_markers(scene, frame, masks)
    _draw_spots(scene.obstacles, OBSTACLE_RADIUS_M, frame, masks[OBSTACLE])
    _draw_path(scene.path, frame, masks[PATH])
    _draw_ellipse(scene.robot, scene.ellipse, frame, masks[ELLIPSE])
    _draw_robot(scene.robot, scene.robot_radius, frame, masks[ROBOT])

    codes = _pack(masks, rows, cols)
    floor = codes[_FLOOR_SLOT] == 0xFF
    codes[_FLOOR_SLOT] = 0
    # The stipple keeps out of characters with anything else in them, where it would
    # read as a ragged edge on a wall.
    codes[UNSEEN][codes[WALL:].any(axis=0)] = 0
    inked = codes > 0
    top = (inked * np.arange(len(codes), dtype=np.int8)[:, None, None]).max(axis=0)
    chars = np.bitwise_or.reduce(codes, axis=0).astype(np.uint32) + 0x2800
    # A label must fit inside its room at this zoom, clear of the robot, the doors, the
    # markers and the obstacles, and of the path and the ellipse where it can be.
    solid = [DOOR_OPEN, DOOR_CLOSED, MARKER, OBSTACLE, MARKER_SEEN, MARKER_REJECTED, ROBOT]
    room = floor & ~inked[solid].any(axis=0)
    _place_labels(scene.labels, viewport, room, inked[PATH] | inked[ELLIPSE], chars, top)
    return _styled(chars, top, layer_styles(truecolor))


def _pack(masks: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Stacked dot masks as Braille bits, one byte per character of each mask; eight
    shifts run several times faster than np.einsum or np.packbits here."""
    blocks = masks.reshape(len(masks), rows, 4, cols, 2)
    codes = np.zeros((len(masks), rows, cols), np.uint8)
    for h, bits in enumerate(_BITS):
        for w, bit in enumerate(bits):
            codes |= blocks[:, :, h, :, w] << bit
    return codes


def _bins(first: float, step: float, count: int, size: int) -> tuple[slice, np.ndarray, np.ndarray]:
    """Which of `size` cells each of `count` dots along one axis takes.

    `first` is the first dot's leading edge in cell units and `step` the cells per dot.
    Zoomed out, the cells are shared out so that each goes to exactly one dot and a wall
    one cell thin still lands in some dot; zoomed in, a dot shows the cell under its
    middle. Returns the dots that touch the grid and the [low, high) cells of each.
    """
    if step >= 1:
        edges = np.floor(first + step * np.arange(count + 1)).astype(np.int64)
        low, high = edges[:-1], edges[1:]
    else:
        low = np.floor(first + step * (np.arange(count) + 0.5)).astype(np.int64)
        high = low + 1
    low, high = np.clip(low, 0, size), np.clip(high, 0, size)
    on_grid = np.flatnonzero(high > low)
    if not len(on_grid):
        return slice(0, 0), low[:0], high[:0]
    return slice(on_grid[0], on_grid[-1] + 1), low[on_grid], high[on_grid]


def _max_along(block: np.ndarray, low: np.ndarray, high: np.ndarray, axis: int) -> np.ndarray:
    """The maximum of `block` over cells [low, high) along `axis`, for each bin.

    A whole bin is `span` + 1 cells at most and `span` at least, so a running maximum
    over `span` cells (cv2.dilate), read at both ends of a bin, covers it: a few times
    faster than np.maximum.reduceat. Bins cut short by the grid's edge are done alone.
    """
    span = max(1, int(np.max(high - low)) - 1)
    running = block
    if span > 1:
        kernel = np.ones((1, span) if axis == 1 else (span, 1), np.uint8)
        running = cv2.dilate(block, kernel, anchor=(0, 0))
    pooled = np.maximum(np.take(running, low, axis), np.take(running, high - span, axis))
    for i in np.flatnonzero(high - low < span):
        cut = block[:, low[i] : high[i]] if axis == 1 else block[low[i] : high[i]]
        pooled[(slice(None), i) if axis == 1 else i] = cut.max(axis=axis)
    return pooled


def _pool(grid: OccupancyGrid, viewport: Viewport, cols: int, rows: int) -> np.ndarray:
    """The highest cell rank under each dot: max pooling, so walls never vanish."""
    (left, top), cell = viewport.corner(cols, rows), grid.resolution
    step = viewport.metres_per_dot / cell
    grid_rows, grid_cols = grid.shape
    grid_top = grid.origin[1] + grid_rows * cell
    across, col_low, col_high = _bins((left - grid.origin[0]) / cell, step, 2 * cols, grid_cols)
    down, row_low, row_high = _bins((grid_top - top) / cell, step, 4 * rows, grid_rows)
    rank = np.zeros((4 * rows, 2 * cols), np.uint8)
    if len(col_low) and len(row_low):
        # Only the visible part of the grid is ranked and pooled: zoomed in, that is small.
        c0, r0 = col_low[0], row_low[0]
        block = cv2.LUT(grid.cells[r0 : row_high[-1], c0 : col_high[-1]], _RANK)
        block = _max_along(block, col_low - c0, col_high - c0, axis=1)
        rank[down, across] = _max_along(block, row_low - r0, row_high - r0, axis=0)
    return rank


class _Frame:
    """Maps metres to cv2's fixed-point dot coordinates, where (0, 0) is the middle of the
    top-left dot."""

    def __init__(self, viewport: Viewport, cols: int, rows: int) -> None:
        (self.left, self.top), self.step = viewport.corner(cols, rows), viewport.metres_per_dot
        self.shape = (4 * rows, 2 * cols)

    def dots(self, points) -> np.ndarray:
        xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        col = (xy[:, 0] - self.left) / self.step - 0.5
        row = (self.top - xy[:, 1]) / self.step - 0.5
        # Far-off points are pulled in so that the fixed-point numbers cannot overflow;
        # cv2 clips lines to the image itself.
        fixed = np.clip(np.stack((col, row), axis=1), -1e6, 1e6) * _ONE
        return np.round(fixed).astype(np.int32)


def _draw_doors(doors: tuple[DoorMark, ...], frame: _Frame, masks: np.ndarray) -> None:
    """Each door as a line the width of its doorway, across the gap in its wall."""
    if not doors:
        return
    centres = np.array([door.centre for door in doors], dtype=np.float64)
    halves = np.array([door.along for door in doors]) * [[door.width / 2] for door in doors]
    ends = frame.dots(np.concatenate((centres - halves, centres + halves))).tolist()
    for door, start, end in zip(doors, ends[: len(doors)], ends[len(doors) :], strict=True):
        mask = masks[DOOR_OPEN if door.open else DOOR_CLOSED]
        cv2.line(mask, start, end, 1, 1, cv2.LINE_8, _SHIFT)


def _draw_markers(scene: MapScene, frame: _Frame, masks: np.ndarray) -> None:
    """Each marker a spot in front of its wall, in the layer of what became of it lately."""
    if not scene.markers:
        return
    at = np.array([marker.at for marker in scene.markers], dtype=np.float64)
    facing = np.array([marker.facing for marker in scene.markers])
    spots = at + MARKER_RADIUS_M * np.stack((np.cos(facing), np.sin(facing)), axis=1)
    ids = np.array([marker.id for marker in scene.markers])
    rejected = np.isin(ids, scene.rejected)
    seen = np.isin(ids, scene.seen) & ~rejected
    for layer, chosen in ((MARKER, ~(seen | rejected)), (MARKER_SEEN, seen),
                          (MARKER_REJECTED, rejected)):  # fmt: skip
        _draw_spots(spots[chosen], MARKER_RADIUS_M, frame, masks[layer])


def _draw_spots(
    points: tuple[Point, ...] | np.ndarray, radius_m: float, frame: _Frame, mask: np.ndarray
) -> None:
    """Each point a small disc, and at least a dot: a scan can hold hundreds of obstacles,
    so they are set in one go and grown together."""
    if not len(points):
        return
    col, row = ((frame.dots(points) + _ONE // 2) >> _SHIFT).T
    height, width = frame.shape
    inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
    mask[row[inside], col[inside]] = 1
    radius = round(radius_m / frame.step)
    if radius:
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
        mask[:] = cv2.dilate(mask, disc)


def _draw_path(path: tuple[Point, ...], frame: _Frame, mask: np.ndarray) -> None:
    if path:
        points = frame.dots(path if len(path) > 1 else (*path, *path))
        cv2.polylines(mask, [points], False, 1, 1, cv2.LINE_8, _SHIFT)


def _draw_ellipse(
    robot: tuple[float, float, float] | None,
    ellipse: tuple[float, float, float] | None,
    frame: _Frame,
    mask: np.ndarray,
) -> None:
    """The uncertainty ellipse's outline about the robot, at ELLIPSE_SIGMAS; none while
    the filter has no finite one. Within the robot's disc it is hidden by the robot."""
    outline = _ellipse_dots(robot, ellipse, frame)
    if outline is not None:
        cv2.polylines(mask, [outline], True, 1, 1, cv2.LINE_8, _SHIFT)


def _ellipse_dots(
    robot: tuple[float, float, float] | None,
    ellipse: tuple[float, float, float] | None,
    frame: _Frame,
) -> np.ndarray | None:
    """The ellipse's outline in cv2's fixed-point dots: all that its drawing depends on."""
    if robot is None or ellipse is None or not all(map(math.isfinite, ellipse)):
        return None
    major, minor, angle = ellipse
    major, minor = ELLIPSE_SIGMAS * major, ELLIPSE_SIGMAS * minor
    # Enough corners that each side is about a dot long, for a smooth outline.
    corners = int(np.clip(2 * math.pi * major / frame.step, 16, 720))
    t = np.linspace(0.0, 2 * math.pi, corners, endpoint=False)
    along, across = major * np.cos(t), minor * np.sin(t)
    cos_a, sin_a = math.cos(angle), math.sin(angle)
    outline = np.stack((robot[0] + cos_a * along - sin_a * across,
                        robot[1] + sin_a * along + cos_a * across), axis=1)  # fmt: skip
    return frame.dots(outline)


def _draw_robot(
    robot: tuple[float, float, float] | None, radius_m: float, frame: _Frame, mask: np.ndarray
) -> None:
    """A disc the robot's size and a tick twice as long pointing where it heads. cv2
    draws a disc of any size as at least its middle dot, and the tick is made at least
    two dots long, so that the robot and its heading still show when zoomed right out."""
    dots = _robot_dots(robot, radius_m, frame)
    if dots is None:
        return
    centre, tip, radius = dots
    cv2.circle(mask, centre, radius, 1, -1, cv2.LINE_8, _SHIFT)
    cv2.line(mask, centre, tip, 1, 1, cv2.LINE_8, _SHIFT)


def _robot_dots(
    robot: tuple[float, float, float] | None, radius_m: float, frame: _Frame
) -> tuple[tuple[int, int], tuple[int, int], int] | None:
    """The robot's disc centre, its tick's tip and the disc's radius in cv2's fixed-point
    dots: all that its drawing depends on."""
    if robot is None:
        return None
    x, y, heading = robot
    reach = max(2 * radius_m, 2 * frame.step)
    centre, tip = frame.dots(
        [(x, y), (x + reach * math.cos(heading), y + reach * math.sin(heading))]
    ).tolist()
    return (centre[0], centre[1]), (tip[0], tip[1]), round(radius_m / frame.step * _ONE)


def drawing_key(scene: MapScene, viewport: Viewport, cols: int, rows: int) -> tuple[object, ...]:
    """What `render_map` draws from: two scenes with equal keys in the same view are drawn
    alike, to the dot. The robot and its ellipse are taken as cv2 draws them, in eighths
    of a dot, so that the estimate's every correction, a few micrometres while the robot
    stands still, is not a new drawing (issue 26: the map was drawn again at 20 Hz while
    nothing on it moved). The rest of the scene is taken as it is."""
    frame = _Frame(viewport, cols, rows)
    outline = _ellipse_dots(scene.robot, scene.ellipse, frame)
    return (
        viewport, cols, rows, replace(scene, robot=None, ellipse=None),
        _robot_dots(scene.robot, scene.robot_radius, frame),
        None if outline is None else outline.tobytes(),
    )  # fmt: skip


def _place_labels(
    labels: tuple[tuple[str, Point], ...],
    viewport: Viewport,
    room: np.ndarray,
    path: np.ndarray,
    chars: np.ndarray,
    top: np.ndarray,
) -> None:
    """Write each label centred on its point where it fits in `room`, a character of room
    on either side. It keeps off the path if it can, moving a line up or down, so that
    the path stays whole and a room's name shows beside the robot standing on its point;
    else it covers the path on its own line, as where a path ends at the room's point.
    First come, first placed, so labels never overlap."""
    rows, cols = room.shape
    # Rows of bytes, 1 where a label may go: tested and cleared far faster than arrays.
    off_path = [bytearray(line) for line in (room & ~path).astype(np.uint8)]
    anywhere = [bytearray(line) for line in room.astype(np.uint8)]
    for text, (x, y) in labels:
        col, row = viewport.char_of(x, y, cols, rows)
        # What tells a label apart when it does not fit: room-101 becomes 101.
        number = re.search(r"\d+\Z", text)
        texts = (text, number.group()) if number and number.group() != text else (text,)
        clear = [(t, line, off_path) for t in texts for line in (row, row - 1, row + 1)]
        for candidate, line, free in clear + [(t, row, anywhere) for t in texts]:
            start = col - (len(candidate) - 1) // 2
            end = start + len(candidate)
            if not (0 <= line < rows and start >= 1 and end <= cols - 1):
                continue
            around = slice(start - 1, end + 1)
            if 0 not in free[line][around]:
                chars[line, start:end] = [ord(c) for c in candidate]
                top[line, start:end] = LABEL
                off_path[line][around] = anywhere[line][around] = bytes(end - start + 2)
                break


def _styled(chars: np.ndarray, top: np.ndarray, styles: dict[int, Style | None]) -> Text:
    """The characters as Text with one styled span per run of a line in one layer. The
    spans are made directly: Text.append per run cost more than all the drawing."""
    rows, cols = chars.shape
    lines = np.concatenate((chars, np.full((rows, 1), ord("\n"), np.uint32)), axis=1)
    plain = lines.astype("<u4").tobytes().decode("utf-32-le")[:-1]
    # A run starts at each line's start and wherever the layer changes along a line.
    starts = np.ones((rows, cols), bool)
    starts[:, 1:] = top[:, 1:] != top[:, :-1]
    row, col = np.nonzero(starts)
    end = np.append(col[1:], cols)
    end[np.append(row[1:] != row[:-1], True)] = cols
    offset = row * (cols + 1)
    spans = [
        Span(int(offset[i] + col[i]), int(offset[i] + end[i]), style)
        for i, layer in enumerate(top[row, col].tolist())
        if (style := styles[layer]) is not None
    ]
    return Text(plain, spans=spans, no_wrap=True, overflow="crop", end="")
