"""A built map saved as ROS map_server saves one: a YAML file and a PGM image (issue 29).

The pair is what map_server's documentation describes and map_saver writes: the image
with row 0 at the top, occupied cells 0, free 254 and unknown 205, read back in trinary
mode with the thresholds 0.65 and 0.196 (205 is (255 - 205) / 255 = 0.196..., just above
free_thresh, so unknown). Any ROS tool, and our own reader (ros_map.py, scan_grid.py),
reads it.

Each file is written to a temporary file beside it, flushed to the disk, and renamed
over the old one, the image first: a full disk or a power cut leaves the old pair or the
new image with the old YAML, never a file cut short. The map is the building's layout,
which is nobody else's business: the files are the owner's only (0600), and a folder
made for them too (0700).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from pathlib import Path

import numpy as np

from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.rasterise import grid_image
from giraff_console.private_files import private_folder

# map_server's trinary thresholds, as map_saver writes them.
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196


class MapSaveError(OSError):
    """The map could not be saved; the message names the file and why, in one line."""


def save_ros_map(grid: OccupancyGrid, yaml_path: str | Path) -> tuple[Path, Path]:
    """Write `grid` as `yaml_path` and the PGM beside it (its name with .pgm); return
    both paths. MapSaveError if they cannot be written (the old files, if any, stay)."""
    yaml_path = Path(yaml_path)
    if yaml_path.suffix != ".yaml":
        raise MapSaveError(f"{yaml_path}: a map_server map's file ends in .yaml")
    image_path = yaml_path.with_suffix(".pgm")
    try:
        private_folder(yaml_path.parent)
    except OSError as error:
        raise MapSaveError(f"{yaml_path.parent}: cannot make the folder: "
                           f"{error.strerror or error}") from None  # fmt: skip
    _replace(image_path, pgm(grid))
    _replace(yaml_path, map_yaml(grid, image_path.name).encode())
    return yaml_path, image_path


def pgm(grid: OccupancyGrid) -> bytes:
    """The grid as a binary PGM (P5), map_server's shades."""
    rows, cols = grid.shape
    return f"P5\n{cols} {rows}\n255\n".encode() + np.ascontiguousarray(grid_image(grid)).tobytes()


def map_yaml(grid: OccupancyGrid, image: str) -> str:
    """map_server's YAML for `grid` drawn in `image`: the origin is the lower-left
    corner of the lower-left cell, yaw 0."""
    x, y = (_number(value) for value in grid.origin)
    # map_saver writes the name bare; one YAML would misread (a colon, a space) is quoted.
    name = image if re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", image) else json.dumps(image)
    return (
        f"image: {name}\n"
        f"resolution: {_number(grid.resolution)}\n"
        f"origin: [{x}, {y}, 0.0]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\n"
        f"free_thresh: {FREE_THRESH}\n"
        "mode: trinary\n"
    )


def _number(value: float) -> str:
    """A float as YAML reads back the same: to the micrometre, which the cells are
    multiples of, without the float's rounding noise (0.30000000000000004)."""
    return repr(round(float(value), 6) + 0.0)  # + 0.0: no -0.0


def _replace(path: Path, data: bytes) -> None:
    """Put `data` in `path` whole, or leave `path` as it was."""
    if path.is_symlink() or path.is_dir():
        raise MapSaveError(f"{path}: is a link or a folder, not a map's file")
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    except OSError as error:
        raise MapSaveError(f"{path}: cannot write in {path.parent}: "
                           f"{error.strerror or error}") from None  # fmt: skip
    try:
        with os.fdopen(handle, "wb") as out:  # mkstemp made it 0600
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temporary, path)
    except OSError as error:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise MapSaveError(f"{path}: cannot write it: {error.strerror or error}") from None
