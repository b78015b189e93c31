"""ROS map_server maps (`map.yaml` and its image) as a floor plan's grid (thesis §2.6.4).

A building that already runs ROS robots usually has a map built by SLAM and saved by
map_server: a YAML file naming an image, its resolution and origin, and how to read its
pixels. Our `grid:` section follows the same conventions (floorplans/README.md), so
importing one is a matter of checking it as ROS would and copying its keys. Checking
here, with `file:line` messages, matters because the floor plan loader would otherwise
report a bad map as a problem in the imported floor plan, far from the file to fix.

`read_yaml` is shared with the Open-RMF importer (rmf_import.py): both read hand-edited
YAML and report mistakes the way `load_floorplan` does, as `FloorPlanError` problems.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import Any, TypeGuard

import cv2
import numpy as np

from giraff_console.file_limits import current, raising, read_bounded
from giraff_console.planning.floorplan import (
    FloorPlanError,
    GridSpec,
    Problem,
    Where,
    _finite,
    _node_lines,
    dotted,
    load_yaml,
    shown,
)

# The keys nav2's map_server refuses a map without; `mode` is optional there too.
_REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
# Netpbm's kinds (PBM, PGM, PPM, plain and raw): whether the pixels are text, how
# many samples a pixel has, and whether the header gives a largest value.
_NETPBM = {
    b"P1": (True, 1, False), b"P2": (True, 1, True), b"P3": (True, 3, True),
    b"P4": (False, 1, False), b"P5": (False, 1, True), b"P6": (False, 3, True),
}  # fmt: skip
_WHITESPACE = b" \t\r\n\v\f"
# A PNG's signature, then its first chunk, IHDR: length, name, width, height.
_PNG = b"\x89PNG\r\n\x1a\n"
_IHDR = struct.Struct(">I4sII")


class GridImageError(OSError):
    """A grid image that cannot be read as a grid; the message names the file and why.
    An OSError, as a missing image is, so that whoever reports one reports the other."""


def read_grid_image(path: Path) -> np.ndarray:
    """The pixels of a grid image (a PGM or a PNG), as OpenCV reads them, unchanged.

    GridImageError if it cannot be read, if grid_image_problem finds a problem in it
    (larger than the limits, or a Netpbm image whose pixels do not fill its header's
    size), or if OpenCV cannot decode it."""
    try:
        data = read_bounded(path, "image_bytes")
    except OSError as error:
        raise GridImageError(f"{path}: cannot read it: {error.strerror or error}") from None
    mismatch = grid_image_problem(data)
    if mismatch is not None:
        raise GridImageError(f"{path}: {mismatch}")
    pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise GridImageError(f"{path}: not an image OpenCV can read")
    return pixels


def grid_image_problem(data: bytes) -> str | None:
    """What keeps `data` from being a grid image, found from its header before anything
    is decoded; None if it may be decoded. It must be a PGM (or another Netpbm image) or
    a PNG, of no more pixels than the `image_pixels` limit: OpenCV would allocate what
    the header claims (a PNG claiming 100,000 x 100,000 makes it raise), and planning
    on a grid takes about 30 bytes a cell."""
    if not data:
        return "the file is empty"
    if data[:2] in _NETPBM:
        return netpbm_mismatch(data)
    if not data.startswith(_PNG):
        return "not a PGM or PNG image"
    if len(data) < len(_PNG) + _IHDR.size:
        return "a PNG cut short in its header"
    _, chunk, width, height = _IHDR.unpack_from(data, len(_PNG))
    if chunk != b"IHDR":
        return "a PNG whose header (IHDR) is not where it belongs"
    return _too_many_pixels(width, height)


def _too_many_pixels(width: int, height: int) -> str | None:
    most = current().image_pixels
    if width * height <= most:
        return None
    return (
        f"its header says {width} x {height} pixels, more than the {most:,} this console "
        f"reads ({raising('image_pixels')})"
    )


def netpbm_mismatch(data: bytes) -> str | None:
    """What is wrong with a Netpbm image's header, or between it and its pixels; None
    when it is right, or when `data` is not a Netpbm image at all (a PNG checks itself).
    A few whitespace bytes after the pixels, fewer than a row, are allowed: some writers
    end the file with a newline. No data at all is wrong whatever the kind: OpenCV's
    imdecode raises (`!buf.empty()`) for it rather than returning None, so every reader
    of grid images (here, and floorplan.py's check) must refuse it first."""
    if not data:
        return "the file is empty"
    kind = data[:2]
    if kind not in _NETPBM:
        return None
    plain, samples, has_largest = _NETPBM[kind]
    fields: list[int] = []
    at = 2
    while len(fields) < (3 if has_largest else 2):
        while at < len(data) and (data[at] in _WHITESPACE or data[at] == ord("#")):
            if data[at] == ord("#"):  # a comment, to the end of its line
                while at < len(data) and data[at] not in b"\r\n":
                    at += 1
            else:
                at += 1
        start = at
        while at < len(data) and 48 <= data[at] <= 57:
            at += 1
        if at == start:
            return "its header should give the width, the height" + (
                " and the largest value, as whole numbers" if has_largest else ", as whole numbers"
            )
        fields.append(int(data[start:at]))
    width, height = fields[0], fields[1]
    largest = fields[2] if has_largest else 1
    if width < 1 or height < 1:
        return f"its header says {width} x {height} pixels: an image needs at least one"
    if not 1 <= largest <= 65535:
        return f"its header gives {largest} as the largest value, not 1 to 65535"
    too_large = _too_many_pixels(width, height)
    if too_large is not None:
        return too_large
    if at >= len(data) or data[at] not in _WHITESPACE:
        return "its header should end with a space or a newline before the pixels"
    pixels = data[at + 1 :]
    size = f"its header says {width} x {height} pixels"
    if plain:
        # Plain PBM digits need no space between them; the others are numbers.
        found = pixels.count(b"0") + pixels.count(b"1") if kind == b"P1" else len(pixels.split())
        wanted = width * height * samples
        unit, extra = "values", 0
    else:
        row = math.ceil(width / 8) if kind == b"P4" else width * samples * (1 + (largest > 255))
        wanted, found = row * height, len(pixels)
        unit = "bytes"
        tail = pixels[wanted:]
        extra = len(tail) if len(tail) < row and not tail.strip(_WHITESPACE) else 0
    if found - extra > wanted:
        return (
            f"{size} ({wanted} {unit}) but it holds {found} {unit} of pixels: the header "
            f"is narrower or shorter than the image, which would read as a garbled grid; "
            f"write the image's true width and height in it"
        )
    if found < wanted:
        return (
            f"{size} ({wanted} {unit}) but it holds only {found} {unit} of pixels: the "
            f"file is cut short, or the header is wider or taller than the image"
        )
    return None


def read_yaml(path: Path) -> tuple[dict[Any, Any], dict[Where, int]]:
    """The mapping in the YAML file at `path`, and the line of each key and list item in
    it; raises FloorPlanError if the file cannot be read, is not YAML, is not a mapping or
    writes a key twice (loaders silently keep the last)."""
    node, document = load_yaml(path)
    if not isinstance(document, dict):
        message = f"should be a YAML mapping of keys, not {shown(document)}"
        raise FloorPlanError([Problem(path, None, message)])
    lines: dict[Where, int] = {}
    duplicates: list[tuple[Where, str, int]] = []
    _node_lines(node, (), lines, duplicates)
    if duplicates:
        raise FloorPlanError(
            [
                Problem(path, line, f"duplicate key {dotted((*where, key))}")
                for where, key, line in duplicates
            ]
        )
    return document, lines


def _is_number(value: Any) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and _finite(value)


def read_ros_map(path: str | Path) -> GridSpec:
    """The grid a ROS map_server `map.yaml` describes, its image path resolved; raises
    FloorPlanError listing every problem in the file."""
    path = Path(path)
    document, lines = read_yaml(path)
    problems: list[Problem] = []

    def add(key: str, message: str) -> None:
        problems.append(Problem(path, lines.get((key,)), message))

    for key in _REQUIRED:
        if key not in document:
            add(key, f"missing key {key} (ROS map_server needs it)")
    image = document.get("image")
    if "image" in document and not (isinstance(image, str) and image.strip()):
        add("image", f"image should name the map's image file, not {shown(image)}")
        image = None
    resolution = document.get("resolution")
    if "resolution" in document and not (_is_number(resolution) and resolution > 0):
        add(
            "resolution", f"resolution should be metres per pixel, above 0, not {shown(resolution)}"
        )
    origin = document.get("origin")
    if "origin" in document and not (
        isinstance(origin, list) and len(origin) == 3 and all(map(_is_number, origin))
    ):
        add("origin", f"origin should be three numbers [x, y, yaw], not {shown(origin)}")
    negate = document.get("negate")
    # ROS reads negate as an int, or failing that as a bool: 0, 1, true and false.
    if "negate" in document and (negate not in (0, 1) or isinstance(negate, float)):
        add("negate", f"negate should be 0 or 1, not {shown(negate)}")
    thresholds = {}
    for key in ("occupied_thresh", "free_thresh"):
        value = document.get(key)
        if key in document and not (_is_number(value) and 0 <= value <= 1):
            add(key, f"{key} should be a number from 0 to 1, not {shown(value)}")
        else:
            thresholds[key] = value
    occupied, free = thresholds.get("occupied_thresh"), thresholds.get("free_thresh")
    if occupied is not None and free is not None and free > occupied:
        add("free_thresh", f"free_thresh {free} is above occupied_thresh {occupied}")
    mode = document.get("mode", "trinary")
    if mode == "raw":
        # Raw pixels are occupancy values themselves; our grid reads them by thresholds.
        add("mode", "mode raw is not supported: save the map in trinary or scale mode")
    elif mode not in ("trinary", "scale"):
        # Scale mode thresholds exactly as trinary does, so both read the same here.
        add("mode", f"mode should be trinary, scale or raw, not {shown(mode)}")
    image_path = None
    if image is not None:
        image_path = path.parent / image  # ROS: relative to the map.yaml, or absolute
        if not image_path.exists():  # a FIFO or a device is refused by read_grid_image
            add("image", f"image {image!r} is missing (looked for {image_path})")
        else:
            try:
                read_grid_image(image_path)
            except GridImageError as error:
                add("image", f"image {image!r} cannot be used: {error}")
    if problems:
        raise FloorPlanError(sorted(problems, key=lambda problem: problem.line or 0))
    assert image_path is not None
    # Every key is there and checked, or there would have been problems.
    assert resolution is not None and origin is not None and negate is not None
    assert occupied is not None and free is not None
    return GridSpec(
        image_path,
        float(resolution),
        (float(origin[0]), float(origin[1]), float(origin[2])),
        int(negate),
        float(occupied),
        float(free),
    )


def grid_section(grid: GridSpec, image: str) -> dict[str, Any]:
    """Our floor plan's `grid:` section for `grid`, with its image found at `image`
    (relative to the floor plan file, or absolute)."""
    return {
        "image": image,
        "resolution": grid.resolution,
        "origin": list(grid.origin),
        "negate": grid.negate,
        "occupied_thresh": grid.occupied_thresh,
        "free_thresh": grid.free_thresh,
    }
