"""Printable pages for a floor plan's markers: one page per marker, at true size.

Each page holds the marker's black square at its printed size from the plan, with white
paper round it, and says in words where it goes: the room, the wall, how far from the
nearest doorway or corner and how high; and a 100 mm line to check that it was printed
at actual size, since a print scaled to fit the page makes every distance the robot
measures from it wrong by the same factor. Pages are PNG at 300 dpi, with the resolution
in the file so that viewers print them at size, and all of them in one PDF besides.

The pages are pure black and white (no anti-aliasing), so that what is printed is
exactly OpenCV's pattern for the id; tests run cv2.aruco's detector on them.
"""

from __future__ import annotations

import math
import struct
import unicodedata
import zlib
from pathlib import Path

import cv2
import numpy as np

from giraff_console.planning.floorplan import FloorPlan, Landmarks, Marker
from giraff_console.planning.landmarks import cells, marker_image, where_it_goes
from giraff_console.private_files import open_private, private_folder, write_private

DPI = 300
# ISO paper, width by height in metres, smallest first: the first that holds the page.
PAPERS = (("A4", 0.210, 0.297), ("A3", 0.297, 0.420), ("A2", 0.420, 0.594),
          ("A1", 0.594, 0.841))  # fmt: skip
MARGIN_M = 0.012
# White round the black square, at least a cell (AprilTag's own white border) and never
# less than this: nothing printed comes nearer, and the paper may be trimmed to it.
QUIET_ZONE_M = 0.02
FONT = cv2.FONT_HERSHEY_SIMPLEX
SCALE_BAR_M = 0.100


def pixels(metres: float) -> int:
    return round(metres / 0.0254 * DPI)


def ascii_text(text: str) -> str:
    """OpenCV's fonts draw ASCII only: accents dropped (Küche as Kuche), others as '?'."""
    plain = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    return "".join(c if " " <= c <= "~" else "?" for c in plain) if plain else "?"


class _Lines:
    """Lines of text laid out at a given height, wrapped to a width, in pixels."""

    def __init__(self, width: int) -> None:
        self.width = width
        self.lines: list[tuple[str, float, int, int]] = []  # text, scale, thickness, advance

    def add(self, text: str, height_m: float, gap_m: float = 0.4) -> None:
        cap = pixels(height_m)
        scale = cap / cv2.getTextSize("H", FONT, 1.0, 1)[0][1]
        thickness = max(2, round(scale * 1.6))
        words: list[str] = []
        for word in ascii_text(text).split():
            trial = " ".join([*words, word])
            if words and cv2.getTextSize(trial, FONT, scale, thickness)[0][0] > self.width:
                self.lines.append((" ".join(words), scale, thickness, round(cap * (1 + gap_m))))
                words = [word]
            else:
                words.append(word)
        self.lines.append((" ".join(words), scale, thickness, round(cap * (1 + gap_m))))

    @property
    def height(self) -> int:
        return sum(advance for *_, advance in self.lines)

    def draw(self, page: np.ndarray, left: int, top: int) -> None:
        y = top
        for text, scale, thickness, advance in self.lines:
            (_, cap), _ = cv2.getTextSize("H", FONT, scale, thickness)
            cv2.putText(page, text, (left, y + cap), FONT, scale, 0, thickness, cv2.LINE_8)
            y += advance


def marker_page(plan: FloorPlan, landmarks: Landmarks, marker: Marker) -> np.ndarray:
    """The printed page of one marker: greyscale, 0 or 255, DPI pixels to the inch."""
    square = pixels(landmarks.size)
    quiet = max(pixels(QUIET_ZONE_M), math.ceil(square / cells(landmarks.family)))
    margin = pixels(MARGIN_M)
    place = where_it_goes(plan, marker)
    for _, width_m, height_m in PAPERS:
        width, height = pixels(width_m), pixels(height_m)
        text_width = width - 2 * margin
        header, footer = _Lines(text_width), _Lines(text_width)
        header.add(f"Marker {marker.id}", 0.011)
        if place is not None:
            header.add(f"{place.room.label} ({place.room.id}), {place.wall}", 0.0055)
            header.add(f"Facing into the room, flat on the wall, this way up; {place.beside} "
                       f"as you face the wall, {marker.height:.2f} m above the floor.",
                       0.0038)  # fmt: skip
        footer.add(f"Print at actual size (100 %, not fit to page): the black square must "
                   f"measure {landmarks.size * 1000:.0f} mm and this line "
                   f"{SCALE_BAR_M * 1000:.0f} mm:", 0.0032)  # fmt: skip
        bar_top = footer.height
        footer.lines.append(("", 1.0, 1, pixels(0.012)))
        footer.add(f"{landmarks.family} id {marker.id}; {plan.name} ({plan.path.name}); map "
                   f"x {marker.at[0]:.3f} m, y {marker.at[1]:.3f} m, facing {marker.facing:g} "
                   f"deg. Trim no closer than {QUIET_ZONE_M * 1000:.0f} mm to the black "
                   f"square.", 0.0026)  # fmt: skip
        needed = 2 * margin + header.height + 2 * quiet + square + footer.height
        # The margin is white paper too: the quiet zone may reach into it.
        if needed <= height and square + 2 * quiet <= width:
            break
    else:
        raise ValueError(f"a {landmarks.size} m marker does not fit on {PAPERS[-1][0]} paper")
    page = np.full((height, width), 255, dtype=np.uint8)
    header.draw(page, margin, margin)
    left = (width - square) // 2
    top = margin + header.height + quiet
    page[top : top + square, left : left + square] = marker_image(
        landmarks.family, marker.id, square
    )
    # "This way up", by the title: the pose from a marker turned on the wall is turned too.
    arrow_x, arrow_top = width - margin - pixels(0.006), margin
    arrow_bottom = margin + header.lines[0][3]
    cv2.arrowedLine(page, (arrow_x, arrow_bottom), (arrow_x, arrow_top), 0, pixels(0.0012),
                    cv2.LINE_8, tipLength=0.35)  # fmt: skip
    up = _Lines(width)
    up.add("UP", 0.005)
    up.draw(page, arrow_x - pixels(0.02), arrow_top + pixels(0.003))
    footer_top = top + square + quiet
    footer.draw(page, margin, footer_top)
    bar_y = footer_top + bar_top + pixels(0.004)
    bar_left, bar_right = margin, margin + pixels(SCALE_BAR_M)
    cv2.rectangle(page, (bar_left, bar_y), (bar_right, bar_y + pixels(0.0008)), 0, -1)
    for mm in range(0, round(SCALE_BAR_M * 1000) + 1, 10):
        x = bar_left + round((bar_right - bar_left) * mm / (SCALE_BAR_M * 1000))
        tick = pixels(0.004 if mm % 50 == 0 else 0.0025)
        cv2.rectangle(page, (x - 2, bar_y - tick), (x + 2, bar_y), 0, -1)
    return np.where(page > 127, 255, 0).astype(np.uint8)


def _png(page: np.ndarray) -> bytes:
    """The page as a 1-bit PNG whose pHYs chunk says DPI, so it prints at true size."""
    ok, data = cv2.imencode(".png", page, [cv2.IMWRITE_PNG_BILEVEL, 1])
    if not ok:
        raise ValueError("OpenCV could not encode the page as PNG")
    per_metre = round(DPI / 0.0254)
    body = b"pHYs" + struct.pack(">IIB", per_metre, per_metre, 1)
    chunk = struct.pack(">I", 9) + body + struct.pack(">I", zlib.crc32(body))
    raw = data.tobytes()
    return raw[:33] + chunk + raw[33:]  # after the signature (8) and IHDR (25)


def write_pages(plan: FloorPlan, folder: Path) -> list[Path]:
    """One PNG per marker (marker-007.png) and markers.pdf with every page, in `folder`;
    the paths written. ValueError for a plan without markers."""
    landmarks = plan.landmarks
    if landmarks is None or not landmarks.markers:
        raise ValueError(f"{plan.path} has no markers: `giraff-console floorplan landmarks "
                         f"{plan.path}` places them")  # fmt: skip
    # The pages say where each marker hangs in the building: the operator's alone, as
    # everything the robot writes is (private_files.py).
    private_folder(folder)
    written = []
    pdf = _Pdf(folder / "markers.pdf")
    try:
        for marker in landmarks.markers:
            page = marker_page(plan, landmarks, marker)
            path = folder / f"marker-{marker.id:03d}.png"
            write_private(path, _png(page))
            written.append(path)
            pdf.add(page)
    finally:
        pdf.close()
    return [*written, pdf.path]


class _Pdf:
    """A PDF of 1-bit page images, each at its size at DPI: the least a PDF needs, written
    as pages come so that a hundred pages never sit in memory together."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.out = open_private(path, "wb")
        self.offsets: list[int] = []
        self.pages: list[int] = []
        self.out.write(b"%PDF-1.4\n%\xe2\xe3\xcf\xd3\n")
        self._reserve(2)  # 1: the catalogue, 2: the page tree, written at the end

    def _reserve(self, count: int) -> None:
        self.offsets += [0] * count

    def _object(self, body: bytes, number: int | None = None) -> int:
        if number is None:
            self.offsets.append(0)
            number = len(self.offsets)
        self.offsets[number - 1] = self.out.tell()
        self.out.write(b"%d 0 obj\n" % number + body + b"\nendobj\n")
        return number

    def add(self, page: np.ndarray) -> None:
        height, width = page.shape
        bits = zlib.compress(np.packbits(page > 127, axis=1).tobytes())
        image = self._object(
            b"<< /Type /XObject /Subtype /Image /Width %d /Height %d /ColorSpace /DeviceGray "
            b"/BitsPerComponent 1 /Filter /FlateDecode /Length %d >>\nstream\n"
            % (width, height, len(bits))
            + bits
            + b"\nendstream"
        )
        w, h = width / DPI * 72, height / DPI * 72
        draw = b"q %.3f 0 0 %.3f 0 0 cm /Im Do Q" % (w, h)
        content = self._object(b"<< /Length %d >>\nstream\n" % len(draw) + draw + b"\nendstream")
        self.pages.append(
            self._object(
                b"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 %.3f %.3f] /Contents %d 0 R "
                b"/Resources << /XObject << /Im %d 0 R >> >> >>" % (w, h, content, image)
            )
        )

    def close(self) -> None:
        if self.out.closed:
            return
        kids = b" ".join(b"%d 0 R" % page for page in self.pages)
        self._object(b"<< /Type /Catalog /Pages 2 0 R >>", 1)
        self._object(b"<< /Type /Pages /Kids [%s] /Count %d >>" % (kids, len(self.pages)), 2)
        xref = self.out.tell()
        self.out.write(b"xref\n0 %d\n0000000000 65535 f \n" % (len(self.offsets) + 1))
        for offset in self.offsets:
            self.out.write(b"%010d 00000 n \n" % offset)
        self.out.write(b"trailer\n<< /Size %d /Root 1 0 R >>\nstartxref\n%d\n%%%%EOF\n"
                       % (len(self.offsets) + 1, xref))  # fmt: skip
        self.out.close()
