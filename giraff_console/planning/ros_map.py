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

from pathlib import Path
from typing import Any, TypeGuard

import cv2

from giraff_console.planning.floorplan import (
    FloorPlanError,
    GridSpec,
    Problem,
    Where,
    _dotted,
    _finite,
    _node_lines,
    load_yaml,
    shown,
)

# The keys nav2's map_server refuses a map without; `mode` is optional there too.
_REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")


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
                Problem(path, line, f"duplicate key {_dotted((*where, key))}")
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
        if not image_path.is_file():
            add("image", f"image {image!r} is missing (looked for {image_path})")
        elif cv2.imread(str(image_path), cv2.IMREAD_UNCHANGED) is None:
            add("image", f"image {image!r} is not an image OpenCV can read")
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
