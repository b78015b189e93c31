"""Three test buildings unlike the example care home, for issue 25 ("Any building, a
real robot"): each comes into the console the way a care home would bring it.

- `rmf_clinic`: an Open-RMF traffic-editor map, imported by `floorplan import` (no
  outlines; the grid drawn from its walls).
- `scanned_home`: a ROS map_server scan with furniture, clutter, speckle and 0.8 m doors,
  made a plan by `floorplan rooms` (rooms `room-N`, the scan its grid).
- `walled_wing`: a plan written by hand with room outlines, 38 rooms in two wings and a
  dead-end corridor round a hub, its grid drawn from the outlines.

Each generator is deterministic, writes its files into a given folder and returns the
plan's path; `put_up_markers` then runs `floorplan landmarks` on it. The tests
(test_buildings.py) and the benchmark (bench/any_building.py) both build them here, so
they measure the same buildings.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from tests.buildings.console import Markers, put_up_markers
from tests.buildings.rmf_clinic import rmf_clinic
from tests.buildings.scanned_home import scanned_home
from tests.buildings.walled_wing import walled_wing

BUILDINGS: dict[str, Callable[[Path], Path]] = {
    "rmf_clinic": rmf_clinic,
    "scanned_home": scanned_home,
    "walled_wing": walled_wing,
}

__all__ = ["BUILDINGS", "Markers", "put_up_markers", "rmf_clinic", "scanned_home",
           "walled_wing"]  # fmt: skip
