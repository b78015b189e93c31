"""A grid image whose pixels do not fill its header's size is an error naming the file
and what is wrong, never a garbled grid (issue 16); and doors on the grid are checked."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import FloorPlanError, check_floorplan, load_floorplan
from giraff_console.planning.ros_map import (
    GridImageError,
    netpbm_mismatch,
    read_grid_image,
    read_ros_map,
)
from giraff_console.planning.route_planner import walls_of
from tests.planning.scanned_building import PLAN, scanned_image, write_scanned_plan

# A map 60 pixels wide and 40 high, a wall across it.
IMAGE = np.full((40, 60), 254, dtype=np.uint8)
IMAGE[10:12, :] = 0
PIXELS = IMAGE.tobytes()


def pgm(tmp_path: Path, header: bytes, pixels: bytes = PIXELS) -> Path:
    path = tmp_path / "map.pgm"
    path.write_bytes(header + pixels)
    return path


def test_a_header_narrower_than_its_pixels_is_an_error_not_a_garbled_grid(tmp_path):
    # OpenCV alone reads this as 50 x 40 pixels, each row starting 10 pixels on.
    path = pgm(tmp_path, b"P5\n50 40\n255\n")
    with pytest.raises(GridImageError) as caught:
        read_grid_image(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: its header says 50 x 40 pixels (2000 bytes)")
    assert "holds 2400 bytes" in message and "narrower" in message


def test_more_pixels_than_the_header_says_is_an_error(tmp_path):
    path = pgm(tmp_path, b"P5\n60 40\n255\n", PIXELS + bytes(600))
    with pytest.raises(GridImageError, match=r"60 x 40 pixels \(2400 bytes\) but it holds 3000"):
        read_grid_image(path)


def test_fewer_pixels_than_the_header_says_is_an_error(tmp_path):
    path = pgm(tmp_path, b"P5\n60 40\n255\n", PIXELS[:-100])
    with pytest.raises(GridImageError, match=r"holds only 2300 bytes of pixels: the file is cut"):
        read_grid_image(path)


def test_a_plain_pgm_is_counted_in_values(tmp_path):
    path = tmp_path / "map.pgm"
    path.write_text("P2\n# a comment\n3 2\n255\n1 2 3\n4 5\n")
    with pytest.raises(GridImageError, match=r"3 x 2 pixels \(6 values\) but it holds only 5"):
        read_grid_image(path)


def test_a_right_pgm_reads_with_a_comment_and_a_newline_after_its_pixels(tmp_path):
    path = pgm(tmp_path, b"P5\n# from a scan\n60 40\n255\n", PIXELS + b"\n")
    assert np.array_equal(read_grid_image(path), IMAGE)
    assert netpbm_mismatch(b"\x89PNG\r\n") is None  # not Netpbm: its decoder checks it


def test_floorplan_check_names_the_grid_key_and_what_is_wrong(tmp_path):
    path = write_scanned_plan(tmp_path)
    image = scanned_image()
    rows, cols = image.shape
    # The header two pixels narrower than the scan.
    (tmp_path / "scanned.pgm").write_bytes(b"P5\n%d %d\n255\n" % (cols - 2, rows) + image.tobytes())
    (problem,) = check_floorplan(path)
    assert str(problem).startswith(f"{path}:{PLAN.splitlines().index('grid:') + 2}: grid image ")
    assert f"scanned.pgm': its header says {cols - 2} x {rows} pixels" in problem.message


def test_walls_of_and_read_ros_map_refuse_it_too(tmp_path):
    path = write_scanned_plan(tmp_path)
    plan = load_floorplan(path)
    pgm_path = tmp_path / "scanned.pgm"
    pgm_path.write_bytes(b"P5\n100 100\n255\n" + bytes(10_500))
    with pytest.raises(OSError, match=r"scanned.pgm: its header says 100 x 100 pixels"):
        walls_of(plan)
    map_yaml = tmp_path / "map.yaml"
    map_yaml.write_text(
        "image: scanned.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    with pytest.raises(FloorPlanError) as caught:
        read_ros_map(map_yaml)
    (problem,) = caught.value.problems
    assert problem.line == 1 and "its header says 100 x 100 pixels" in problem.message


def test_floorplan_check_reports_a_door_on_an_occupied_cell(tmp_path, capsys):
    # The middle room's doorway drawn 0.3 m to the side of the gap, on the wall.
    text = PLAN.replace("at: [6, 2.05], width: 1.0", "at: [6.8, 2.05], width: 1.0")
    path = write_scanned_plan(tmp_path, text)
    assert main(["floorplan", "check", str(path)]) == 2
    (line,) = capsys.readouterr().out.splitlines()
    number = next(i for i, row in enumerate(text.splitlines(), 1) if "6.8, 2.05" in row)
    assert line.startswith(f"{path}:{number}: door 'corridor-middle-room' at [6.8, 2.05]")
    assert "is on an occupied cell" in line and "scanned.pgm" in line


def test_floorplan_check_passes_the_scanned_plan(tmp_path, capsys):
    path = write_scanned_plan(tmp_path)
    assert main(["floorplan", "check", str(path)]) == 0
    assert capsys.readouterr().out == f"{path}: no problems\n"


def test_an_empty_image_is_an_error_not_a_traceback(tmp_path, capsys):
    # OpenCV raises cv2.error (`!buf.empty()`) for an empty buffer instead of failing.
    path = write_scanned_plan(tmp_path)
    (tmp_path / "scanned.pgm").write_bytes(b"")
    with pytest.raises(GridImageError, match=r"scanned.pgm: the file is empty"):
        read_grid_image(tmp_path / "scanned.pgm")
    assert main(["floorplan", "check", str(path)]) == 2
    printed = capsys.readouterr().out
    assert "scanned.pgm': the file is empty" in printed


def test_a_16_bit_pgm_reads_as_the_same_grid_as_its_8_bit_self(tmp_path):
    eight = scanned_image()
    sixteen = eight.astype(np.uint16) * 257  # 254 -> 65278, 205 -> 52685, 0 -> 0
    assert cv2.imwrite(str(tmp_path / "wide.pgm"), sixteen)
    read = read_grid_image(tmp_path / "wide.pgm")
    assert read.dtype == np.uint16
    path = write_scanned_plan(tmp_path)
    plan = load_floorplan(path)
    grid8 = walls_of(plan)
    path.write_text(path.read_text().replace("scanned.pgm", "wide.pgm"))
    grid16 = walls_of(load_floorplan(path))
    assert grid8 is not None and grid16 is not None
    assert np.array_equal(grid8.cells, grid16.cells)
