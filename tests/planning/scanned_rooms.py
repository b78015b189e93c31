"""A care home's floor as a SLAM scan leaves it, for `floorplan rooms` to segment.

A corridor 2 m wide runs east-west; five resident rooms open off its north side, and two
resident rooms, a day room and an assisted bathroom off its south side, each through a
0.8 to 1.0 m doorway (the day room through two, one of them a 1.2 m double door). The
walls are 0.15 m thick. The rooms are furnished as a laser at knee height sees them:
beds, wardrobes, armchairs and a sofa as solid blobs, tables and dining chairs as the
specks of their legs. A scan is never clean, so there is more noise besides: ragged wall
faces, single occupied and unknown cells on the floor, a wheelchair parked against the
corridor wall (narrowing it to 1.3 m, as much as a doorway does), unknown space all
round, free rays through the windows, and a patch of garden seen through a window, free
and big enough to stand in but joined to nothing.

Everything is drawn from one seeded generator, so the map is the same on every run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

RESOLUTION = 0.05
ORIGIN = (-1.0, -1.0)
# The building is 24 m by 11 m, in unknown space: 1 m of it round the building, and
# 2.5 m to the north, where the lawn is.
SIZE_M = (26.0, 14.5)
FREE_SHADE, WALL_SHADE, UNKNOWN_SHADE = 254, 0, 205
WALL_M = 0.15
SEED = 16

# The corridor's free floor, and the y of its walls' inner faces.
CORRIDOR = (0.0, 4.5, 24.0, 6.5)
NORTH_FACE, SOUTH_FACE = 6.5, 4.5


@dataclass(frozen=True)
class DrawnRoom:
    name: str
    box: tuple[float, float, float, float]  # free floor: x0, y0, x1, y1, metres
    doorways: tuple[tuple[float, float], ...]  # (x of the centre, width) in the corridor wall

    @property
    def north(self) -> bool:
        return self.box[1] > CORRIDOR[1]

    def contains(self, x: float, y: float) -> bool:
        x0, y0, x1, y1 = self.box
        return x0 <= x <= x1 and y0 <= y <= y1

    def doorway_centres(self) -> list[tuple[tuple[float, float], float]]:
        """Each doorway's centre, in the middle of the corridor wall, and its width."""
        y = NORTH_FACE + WALL_M / 2 if self.north else SOUTH_FACE - WALL_M / 2
        return [((x, y), width) for x, width in self.doorways]


ROOMS = (
    DrawnRoom("north-1", (0.0, 6.65, 4.725, 11.0), ((3.8, 0.9),)),
    DrawnRoom("north-2", (4.875, 6.65, 9.525, 11.0), ((5.8, 0.8),)),
    DrawnRoom("north-3", (9.675, 6.65, 14.325, 11.0), ((13.4, 1.0),)),
    DrawnRoom("north-4", (14.475, 6.65, 19.125, 11.0), ((15.4, 0.9),)),
    DrawnRoom("north-5", (19.275, 6.65, 24.0, 11.0), ((23.0, 0.85),)),
    DrawnRoom("south-1", (0.0, 0.0, 4.725, 4.35), ((3.8, 0.9),)),
    DrawnRoom("south-2", (4.875, 0.0, 9.525, 4.35), ((5.8, 1.0),)),
    DrawnRoom("day-room", (9.675, 0.0, 19.125, 4.35), ((12.0, 1.2), (17.0, 0.9))),
    DrawnRoom("bathroom", (19.275, 0.0, 24.0, 4.35), ((20.4, 0.8),)),
)
DOORWAYS = tuple(doorway for room in ROOMS for doorway in room.doorway_centres())


class _Canvas:
    """The map image, drawn in metres."""

    def __init__(self) -> None:
        self.cols = round(SIZE_M[0] / RESOLUTION)
        self.rows = round(SIZE_M[1] / RESOLUTION)
        self.image = np.full((self.rows, self.cols), UNKNOWN_SHADE, dtype=np.uint8)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return self.rows - round((y - ORIGIN[1]) / RESOLUTION), round((x - ORIGIN[0]) / RESOLUTION)

    def box(self, x0: float, y0: float, x1: float, y1: float, shade: int) -> None:
        r1, c0 = self.cell(x0, y0)
        r0, c1 = self.cell(x1, y1)
        self.image[r0:r1, c0:c1] = shade

    def near_doorways(self, margin: float = 0.2) -> np.ndarray:
        """The cells in and round the doorways, within `margin` of their jambs, which
        the noise keeps out of: a speck there would shut a doorway to the planner, which
        keeps the robot's radius off every occupied or unknown cell."""
        near = np.zeros(self.image.shape, dtype=bool)
        for (x, y), width in DOORWAYS:
            row, col = self.cell(x, y)
            reach = round((width / 2 + margin) / RESOLUTION)
            near[row - reach : row + reach, col - reach : col + reach] = True
        return near

    def disc(self, x: float, y: float, radius: float, shade: int) -> None:
        row, col = self.cell(x, y)
        cv2.circle(self.image, (col, row), max(0, round(radius / RESOLUTION)), shade, -1)


def scanned_image() -> np.ndarray:
    """The map_server image: white free, black occupied, grey unknown, row 0 the top."""
    rng = np.random.default_rng(SEED)
    canvas = _Canvas()
    w = WALL_M
    canvas.box(-w, -w, 24 + w, 11 + w, WALL_SHADE)
    canvas.box(*CORRIDOR, FREE_SHADE)
    for room in ROOMS:
        canvas.box(*room.box, FREE_SHADE)
    for (x, y), width in DOORWAYS:
        canvas.box(x - width / 2, y - w / 2, x + width / 2, y + w / 2, FREE_SHADE)
    _ragged(canvas, rng)
    for room in ROOMS:
        _furnish(canvas, room, rng)
    # A wheelchair parked against the corridor's north wall, clear of the doorways.
    canvas.box(10.5, 5.8, 11.3, 6.5, WALL_SHADE)
    _speckle(canvas, rng)
    # Windows: a laser sees through glass, leaving free rays (too narrow to stand in)
    # outside, and once a patch of lawn 1.5 m by 1.2 m seen whole, joined to nothing.
    for x in (2.0, 7.0, 12.0, 17.0, 21.5):
        canvas.box(x, 11 + w, x + RESOLUTION, 11.8, FREE_SHADE)
    canvas.box(15.5, 11.8, 17.0, 13.0, FREE_SHADE)
    return canvas.image


def _ragged(canvas: _Canvas, rng: np.random.Generator) -> None:
    """Wall faces as a scan draws them: a cell of wall sticking out here, a cell bitten
    out there; never in a doorway, whose width the robot needs."""
    image = canvas.image
    free = image == FREE_SHADE
    wall = image == WALL_SHADE
    kernel = np.ones((3, 3), np.uint8)
    face_free = free & (cv2.dilate(wall.astype(np.uint8), kernel) > 0)
    face_wall = wall & (cv2.dilate(free.astype(np.uint8), kernel) > 0)
    near_door = canvas.near_doorways()
    image[face_free & ~near_door & (rng.random(image.shape) < 0.12)] = WALL_SHADE
    image[face_wall & ~near_door & (rng.random(image.shape) < 0.12)] = FREE_SHADE


def _furnish(canvas: _Canvas, room: DrawnRoom, rng: np.random.Generator) -> None:
    """Furniture as a knee-high laser sees it, placed clear of the way in."""
    x0, y0, x1, y1 = room.box
    width, depth = x1 - x0, y1 - y0

    def at(u: float, v: float) -> tuple[float, float]:
        # Room coordinates: u along the corridor, v from the corridor wall inwards.
        return x0 + u, (y0 + v if room.north else y1 - v)

    def blob(u0: float, v0: float, u1: float, v1: float) -> None:
        (ax, ay), (bx, by) = at(u0, v0), at(u1, v1)
        canvas.box(min(ax, bx), min(ay, by), max(ax, bx), max(ay, by), WALL_SHADE)

    def legs(u: float, v: float, half: float) -> None:
        for du in (-half, half):
            for dv in (-half, half):
                canvas.disc(*at(u + du, v + dv), 0.025, WALL_SHADE)

    door_u = room.doorways[0][0] - x0
    far_side = width - 0.6 if door_u < width / 2 else 0.0
    if room.name == "day-room":
        for u in (2.3, 4.8, 7.2):  # round tables with a dining chair either side
            legs(u, 2.1, 0.3)
            legs(u, 1.4, 0.18)
            legs(u, 2.8, 0.18)
        blob(width - 0.8, 1.2, width, 3.2)  # a sofa against the east wall
        blob(0.0, depth - 0.5, 1.6, depth)  # a sideboard in the far west corner
        return
    if room.name == "bathroom":
        blob(width - 1.0, depth - 1.8, width, depth)  # the bath
        blob(0.0, depth - 0.7, 0.5, depth)  # the toilet
        blob(far_side, 0.0, far_side + 0.6, 0.5)  # a laundry trolley
        return
    middle = width / 2 + rng.uniform(-0.3, 0.3)
    blob(middle - 0.475, depth - 2.05, middle + 0.475, depth)  # the bed, head to the wall
    blob(middle + 0.6, depth - 0.45, middle + 1.05, depth)  # bedside table
    blob(far_side, 0.3, far_side + 0.6, 1.5)  # wardrobe, on the wall away from the door
    chair_u = 0.3 if door_u > width / 2 else width - 1.0
    blob(chair_u, depth - 1.1, chair_u + 0.7, depth - 0.4)  # armchair by the window
    legs(width / 2 + rng.uniform(-0.5, 0.5), 1.3, 0.2)  # a small table


def _speckle(canvas: _Canvas, rng: np.random.Generator) -> None:
    """Single cells a scan gets wrong: occupied and unknown ones on the floor (a few
    dozen, as a tuned SLAM leaves, none in a doorway's way), occupied ones in the unknown
    outside."""
    image = canvas.image
    free = np.argwhere((image == FREE_SHADE) & ~canvas.near_doorways(1.0))
    for shade, count in ((WALL_SHADE, 40), (UNKNOWN_SHADE, 25)):
        picked = free[rng.choice(len(free), size=count, replace=False)]
        image[picked[:, 0], picked[:, 1]] = shade
    unknown = np.argwhere(image == UNKNOWN_SHADE)
    picked = unknown[rng.choice(len(unknown), size=len(unknown) // 300, replace=False)]
    image[picked[:, 0], picked[:, 1]] = WALL_SHADE


MAP_YAML = """\
image: {image}
resolution: {resolution}
origin: [{x}, {y}, 0.0]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
mode: trinary
"""


def write_scanned_map(folder: Path, name: str = "map", image: np.ndarray | None = None,
                      origin: tuple[float, float] = ORIGIN) -> Path:  # fmt: skip
    """The map's PGM (`image`, by default the scan) and its map_server YAML written into
    `folder`; the YAML's path."""
    path = folder / f"{name}.pgm"
    cv2.imwrite(str(path), scanned_image() if image is None else image)
    yaml_path = folder / f"{name}.yaml"
    yaml_path.write_text(MAP_YAML.format(image=path.name, resolution=RESOLUTION,
                                         x=origin[0], y=origin[1]))  # fmt: skip
    return yaml_path


# Scans worse than a tuned SLAM leaves, as a review of `floorplan rooms` found them.


def speckled_image(occupied: float, unknown: float = 0.0, seed: int = 2) -> np.ndarray:
    """The scan with a fraction `occupied` of its free cells turned occupied, and a
    fraction `unknown` turned unknown, anywhere, doorways too: an untuned scan, or one
    taken while people walked about. Half a per cent is a speck every 0.5 m^2."""
    rng = np.random.default_rng(seed)
    image = scanned_image()
    free = image == FREE_SHADE
    image[free & (rng.random(image.shape) < occupied)] = WALL_SHADE
    image[free & (rng.random(image.shape) < unknown)] = UNKNOWN_SHADE
    return image


def half_open_doors_image() -> np.ndarray:
    """The scan with a door leaf in every doorway, hinged at its west jamb and swung 45
    degrees into the room, drawn a cell thick: the way past it is 0.7 of the doorway's
    width, too narrow for the robot in all but the 1.2 m double door."""
    canvas = _Canvas()
    canvas.image = scanned_image()
    for (x, y), width in DOORWAYS:
        into = 1 if y > CORRIDOR[3] else -1  # north rooms lie up the map
        hinge_y = y + into * WALL_M / 2
        top, left = canvas.cell(x - width / 2, hinge_y)
        bottom, right = canvas.cell(x - width / 2 + 0.7 * width, hinge_y + into * 0.7 * width)
        cv2.line(canvas.image, (left, top), (right, bottom), WALL_SHADE, 1)
    return canvas.image


def in_unknown(image: np.ndarray, cells: int) -> np.ndarray:
    """`image` in the middle of unknown space `cells` wide all round, as SLAM packages
    save a fixed canvas (4000 cells a side is a common default) of which the building
    is a corner."""
    return np.pad(image, cells, constant_values=UNKNOWN_SHADE)
