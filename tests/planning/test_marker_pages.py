"""The printed pages of `floorplan landmarks --print`: a marker OpenCV's detector reads,
at its true size, on a page that says where it goes."""

from __future__ import annotations

import re
import struct
import zlib
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from giraff_console.cli.main import main
from giraff_console.planning.floorplan import Landmarks, load_floorplan
from giraff_console.planning.landmarks import aruco_dictionary
from giraff_console.planning.marker_pages import DPI, marker_page, write_pages

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "giraff_console/floorplans/care-home.yaml"
A4 = (3508, 2480)  # rows, columns at 300 dpi


def detect(page: np.ndarray, family: str = "apriltag_36h11") -> tuple[list[int], np.ndarray]:
    detector = cv2.aruco.ArucoDetector(aruco_dictionary(family))
    corners, ids, _ = detector.detectMarkers(page)
    return ([] if ids is None else ids.ravel().tolist()), np.array(corners).reshape(-1, 4, 2)


def side_in_pixels(corners: np.ndarray) -> float:
    return float(np.mean([np.linalg.norm(corners[i] - corners[(i + 1) % 4]) for i in range(4)]))


def few_markers(count: int = 3):
    plan = load_floorplan(EXAMPLE)
    return replace(plan, landmarks=replace(plan.landmarks, markers=plan.landmarks.markers[:count]))


def test_each_png_page_holds_its_marker_at_true_size(tmp_path):
    plan = few_markers()
    written = write_pages(plan, tmp_path)
    assert [path.name for path in written] == [
        "marker-000.png", "marker-001.png", "marker-002.png", "markers.pdf"
    ]  # fmt: skip
    for marker, path in zip(plan.landmarks.markers, written, strict=False):
        page = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        assert page.shape == A4
        ids, corners = detect(page)
        assert ids == [marker.id]
        # 0.16 m at 300 dpi: 1890 pixels, within a pixel's rounding at each edge.
        assert side_in_pixels(corners[0]) == pytest.approx(0.16 / 0.0254 * DPI, abs=2)


def test_a_marker_turned_the_right_way_up_is_upright_on_the_page(tmp_path):
    plan = few_markers(1)
    _, corners = detect(marker_page(plan, plan.landmarks, plan.landmarks.markers[0]))
    # cv2.aruco gives the corners from the marker's own top left, clockwise.
    top_left, top_right = corners[0][0], corners[0][1]
    assert top_left[0] < top_right[0] and abs(top_left[1] - top_right[1]) < 2


def test_the_png_says_its_resolution_so_it_prints_at_size(tmp_path):
    data = write_pages(few_markers(1), tmp_path)[0].read_bytes()
    at = data.index(b"pHYs")
    x, y, unit = struct.unpack(">IIB", data[at + 4 : at + 13])
    assert unit == 1 and x == y == round(300 / 0.0254)
    assert struct.unpack(">I", data[at + 13 : at + 17])[0] == zlib.crc32(data[at : at + 13])


def pdf_pages(path: Path) -> list[np.ndarray]:
    """The page images of a PDF written by write_pages, read back by its xref table."""
    data = path.read_bytes()
    start = int(data.rsplit(b"startxref", 1)[1].split()[0])
    count = int(re.search(rb"xref\n0 (\d+)\n", data[start:]).group(1))
    rows = data[start:].split(b"\n")[3 : 3 + count - 1]
    images = []
    for number, row in enumerate(rows, start=1):
        offset = int(row.split()[0])
        assert data[offset:].startswith(b"%d 0 obj" % number)
        head = data[offset : data.index(b"\n", data.index(b">>", offset))]  # its dictionary
        if b"/Subtype /Image" in head:
            width = int(re.search(rb"/Width (\d+)", head).group(1))
            height = int(re.search(rb"/Height (\d+)", head).group(1))
            length = int(re.search(rb"/Length (\d+)", head).group(1))
            body = data.index(b"stream\n", offset) + len(b"stream\n")
            bits = np.frombuffer(zlib.decompress(data[body : body + length]), dtype=np.uint8)
            pixels = np.unpackbits(bits.reshape(height, -1), axis=1)[:, :width]
            images.append(pixels.astype(np.uint8) * 255)
    assert data.rstrip().endswith(b"%%EOF")
    return images


def test_the_pdf_holds_every_page_at_its_paper_size(tmp_path):
    plan = few_markers(2)
    pdf = write_pages(plan, tmp_path)[-1]
    pages = pdf_pages(pdf)
    assert [detect(page)[0] for page in pages] == [[0], [1]]
    media = re.findall(rb"/MediaBox \[0 0 ([\d.]+) ([\d.]+)\]", pdf.read_bytes())
    # A4 in points: 210 mm by 297 mm.
    assert [(float(w), float(h)) for w, h in media] == [pytest.approx((595.2, 841.92))] * 2


def test_a_marker_too_big_for_a4_goes_on_larger_paper_still_at_true_size():
    plan = few_markers(1)
    big = Landmarks(plan.landmarks.family, 0.3, plan.landmarks.markers)
    page = marker_page(replace(plan, landmarks=big), big, big.markers[0])
    assert page.shape[0] > A4[0] and page.shape[1] > A4[1]
    ids, corners = detect(cv2.resize(page, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA))
    assert ids == [0]
    assert side_in_pixels(corners[0]) * 2 == pytest.approx(0.3 / 0.0254 * DPI, abs=4)


def test_another_family_prints_its_own_pattern(tmp_path):
    plan = few_markers(1)
    other = Landmarks("4x4_50", 0.1, plan.landmarks.markers)
    page = marker_page(replace(plan, landmarks=other), other, other.markers[0])
    assert detect(page, "4x4_50")[0] == [0]
    assert detect(page)[0] == []


def test_the_command_prints_the_plans_markers_and_leaves_it_alone(tmp_path, capsys):
    plan_path = tmp_path / "plan.yaml"
    plan_path.write_text(
        "name: x\nrooms:\n  a: {at: [1, 1], outline: [[0, 0], [2, 0], [2, 2], [0, 2]]}\n"
        "doors: []\nlandmarks:\n  family: apriltag_36h11\n  size: 0.16\n  markers:\n"
        "  - {id: 5, at: [1, 2], height: 1.1, facing: 270}\n"
    )
    before = plan_path.read_text()
    assert main(["floorplan", "landmarks", str(plan_path), "--print", str(tmp_path / "out")]) == 0
    assert "wrote 1 page to" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["marker-005.png", "markers.pdf"]
    assert plan_path.read_text() == before
    page = cv2.imread(str(tmp_path / "out/marker-005.png"), cv2.IMREAD_GRAYSCALE)
    assert detect(page)[0] == [5]


def test_printing_a_plan_without_markers_says_how_to_place_them(tmp_path, capsys):
    fixture = ROOT / "tests/planning/fixtures/small-home.yaml"
    assert main(["floorplan", "landmarks", str(fixture), "--print", str(tmp_path)]) == 2
    assert "has no markers: `giraff-console floorplan landmarks" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
