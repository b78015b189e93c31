"""A built map saved as ROS map_server's YAML and PGM, read back by our own readers."""

from __future__ import annotations

import os
import resource
import signal
import stat
from pathlib import Path

import numpy as np
import pytest
import yaml

from giraff_console.planning.map_building import MapBuilder
from giraff_console.planning.map_saving import MapSaveError, save_ros_map
from giraff_console.planning.ros_map import read_grid_image, read_ros_map
from giraff_console.planning.scan_grid import read_scan
from tests.mapping.buildings import WING_DRIVE, care_home_wing, drive, sweeps


@pytest.fixture(scope="module")
def built() -> MapBuilder:
    walls = care_home_wing()
    truth = drive(WING_DRIVE, 5.5)[:120]
    builder = MapBuilder()
    for k, (pose, scan) in enumerate(zip(truth, sweeps(walls, truth, 360, 4), strict=True)):
        builder.add(pose, scan, k / 5.5)
    return builder


def test_the_saved_map_reads_back_cell_for_cell(built: MapBuilder, tmp_path: Path) -> None:
    grid = built.grid()
    yaml_path, image_path = save_ros_map(grid, tmp_path / "maps" / "wing.yaml")
    spec = read_ros_map(yaml_path)
    assert spec.image == image_path and spec.resolution == grid.resolution
    assert spec.origin == pytest.approx((*grid.origin, 0.0), abs=1e-9)
    scan = read_scan(yaml_path)
    # read_scan crops to the free cells and 1 m round them: the saved crop is within it.
    assert not scan.cropped
    assert np.array_equal(scan.grid.cells, grid.cells)
    assert scan.grid.origin == pytest.approx(grid.origin, abs=1e-9)


def test_the_files_are_map_servers_format(built: MapBuilder, tmp_path: Path) -> None:
    yaml_path, image_path = save_ros_map(built.grid(), tmp_path / "wing.yaml")
    document = yaml.safe_load(yaml_path.read_text())
    assert document == {
        "image": "wing.pgm", "resolution": 0.05, "origin": document["origin"], "negate": 0,
        "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary",
    }  # fmt: skip
    assert document["origin"][2] == 0.0
    data = image_path.read_bytes()
    rows, cols = built.grid().shape
    assert data.startswith(f"P5\n{cols} {rows}\n255\n".encode())
    assert set(np.unique(read_grid_image(image_path)).tolist()) == {0, 205, 254}


def test_the_files_and_a_folder_made_for_them_are_the_owners_only(
    built: MapBuilder, tmp_path: Path
) -> None:
    yaml_path, image_path = save_ros_map(built.grid(), tmp_path / "new" / "wing.yaml")
    assert stat.S_IMODE(yaml_path.stat().st_mode) == 0o600
    assert stat.S_IMODE(image_path.stat().st_mode) == 0o600
    assert stat.S_IMODE(yaml_path.parent.stat().st_mode) == 0o700


def test_a_full_disk_leaves_the_old_map_whole_and_says_so(
    built: MapBuilder, tmp_path: Path
) -> None:
    yaml_path, image_path = save_ros_map(built.grid(), tmp_path / "wing.yaml")
    before = {path: path.read_bytes() for path in (yaml_path, image_path)}
    # A file size limit fails the write as a full disk does (EFBIG rather than ENOSPC).
    limits = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1000, limits[1]))
    try:
        with pytest.raises(MapSaveError, match=r"wing\.pgm: cannot write it"):
            save_ros_map(built.grid(), yaml_path)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, limits)
        signal.signal(signal.SIGXFSZ, handler)
    assert sorted(os.listdir(tmp_path)) == ["wing.pgm", "wing.yaml"]  # no temporary left
    assert {path: path.read_bytes() for path in before} == before


def test_a_map_file_not_ending_in_yaml_is_refused(built: MapBuilder, tmp_path: Path) -> None:
    with pytest.raises(MapSaveError, match=r"ends in \.yaml"):
        save_ros_map(built.grid(), tmp_path / "wing.pgm")
