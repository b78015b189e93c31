"""Writing a floor plan made by a command (`floorplan import`, `floorplan rooms`).

A command that makes a floor plan from something else (an Open-RMF map, a scan) builds
it as a mapping in our schema and hands it here with its grid. Nothing is written that
`floorplan check` would refuse: the plan is written to a temporary folder and loaded
first, and only then to OUT, with its grid image beside it. Nothing is overwritten
without `force`.
"""

from __future__ import annotations

import errno
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import yaml

from giraff_console.planning.floorplan import (
    FloorPlanError,
    GridSpec,
    Problem,
    check_floorplan,
)
from giraff_console.planning.grid import OccupancyGrid
from giraff_console.planning.rasterise import grid_image
from giraff_console.planning.ros_map import grid_section, read_yaml


@dataclass(frozen=True)
class MadePlan:
    """A floor plan a command made, ready to be written."""

    source: Path  # what it was made from, which its problems are reported against
    plan: dict[str, Any]  # a floor plan in our schema, ready to be written as YAML
    notes: list[str]  # what the command decided that the source did not say
    header: str  # the comment that opens the written file
    drawn: OccupancyGrid | None = None  # a grid drawn by the command, to write with it
    # The line of the source each room and door was made from, by id, so that a problem
    # the final check finds in one is told there; a command may leave it empty.
    lines: dict[str, int] = field(default_factory=dict)


def millimetres(value: float) -> float:
    """A coordinate as written: millimetres are plenty; + 0.0 turns -0.0 into 0.0."""
    return round(value, 3) + 0.0


def write_floorplan(
    made: MadePlan, out: str | Path, grid: GridSpec | None = None, force: bool = False
) -> list[Path]:
    """Write `made` to `out` with its grid next to it as `out`'s name with the image's
    suffix: `grid`'s image copied, else the grid the import drew, as a PGM. Return the
    files written. Nothing is written if the result would not load (FloorPlanError naming
    the problems) or, without `force`, if a file to write exists already
    (FileExistsError)."""
    out = Path(out)
    drawn = made.drawn if grid is None else None
    image = None
    if grid is not None:
        image = out.with_suffix(grid.image.suffix)
    elif drawn is not None:
        image = out.with_suffix(".pgm")
    copy_image = image is not None and (
        grid is None or not (image.exists() and image.samefile(grid.image))
    )
    for target in (out, image if copy_image else None):
        if target is not None and target.exists() and not force:
            raise FileExistsError(errno.EEXIST, "already exists", str(target))
    pixels = _pgm(drawn) if drawn is not None else b""
    with tempfile.TemporaryDirectory() as directory:
        trial = Path(directory) / out.name
        if drawn is not None:
            grid = _drawn_spec(drawn, trial.with_suffix(".pgm"))
            grid.image.write_bytes(pixels)
        # Checked against the map's own image, so that nothing is copied for a plan refused.
        section = grid_section(grid, str(grid.image.resolve())) if grid is not None else None
        trial.write_text(_text(made.header, made.plan, section), encoding="utf-8")
        problems = check_floorplan(trial)
        made_from = _made_from(made, trial) if problems else {}
    if problems:
        raise FloorPlanError(
            [Problem(made.source, made_from.get(problem.line or 0), problem.message)
             for problem in problems]
            + [Problem(out, None, "not written: the floor plan made would not load")]
        )  # fmt: skip
    written = []
    section = None
    if grid is not None and image is not None:
        section = grid_section(grid, image.name)
        if drawn is not None:
            image.write_bytes(pixels)
            written.append(image)
        elif copy_image:
            shutil.copyfile(grid.image, image)
            written.append(image)
    out.write_text(_text(made.header, made.plan, section), encoding="utf-8")
    return [out, *written]


def _made_from(made: MadePlan, trial: Path) -> dict[int, int]:
    """For each line of the trial file that is in a room or door, the line of the source
    that room or door was made from (made.lines)."""
    _, lines = read_yaml(trial)
    doors = [door.get("id") for door in made.plan.get("doors", [])]
    found: dict[int, int] = {}
    for where, line in lines.items():
        if len(where) < 2 or where[0] not in ("rooms", "doors"):
            continue
        item = where[1] if where[0] == "rooms" else doors[int(where[1])]
        if isinstance(item, str) and item in made.lines:
            found[line] = made.lines[item]
    return found


def _pgm(grid: OccupancyGrid) -> bytes:
    found, encoded = cv2.imencode(".pgm", grid_image(grid))
    if not found:
        raise OSError("OpenCV could not encode the grid as a PGM")
    return encoded.tobytes()


def _drawn_spec(grid: OccupancyGrid, image: Path) -> GridSpec:
    """The grid section of a drawn grid: map_server's thresholds, which read rasterise's
    shades as free, occupied and unknown."""
    origin = (millimetres(grid.origin[0]), millimetres(grid.origin[1]), 0.0)
    return GridSpec(image, grid.resolution, origin, 0, 0.65, 0.196)


def _text(header: str, plan: dict[str, Any], grid: dict[str, Any] | None) -> str:
    """The floor plan as YAML, its keys in the order floorplans/README.md gives them."""
    ordered: dict[str, Any] = {key: plan[key] for key in ("name", "rooms", "doors") if key in plan}
    if grid is not None:
        ordered["grid"] = grid
    ordered |= {key: value for key, value in plan.items() if key not in ordered}
    body = yaml.safe_dump(ordered, sort_keys=False, default_flow_style=None, allow_unicode=True)
    return header + body
