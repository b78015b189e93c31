"""The clinic of rmf_clinic.py geo-referenced, as traffic-editor saves a building drawn on
a satellite view (`coordinate_system: wgs84`): every vertex `[longitude, latitude, ...]`
in degrees, the clinic's middle in Stockholm (59.33 N, 18.06 E), its x axis east. The
same level is also written in drawing pixels (`reference_image`), so that the two can be
imported and compared.

Design metres become degrees through the plane tangent to the WGS 84 ellipsoid at the
clinic's middle (the median of its vertices' design x and y, which is where the importer
puts its frame's origin), inverted by Newton's method to 0.1 micrometre. An import of the
wgs84 clinic therefore has each design point at (x - mx, y - my), `MIDDLE` = (mx, my),
to within micrometres.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path

from giraff_console.planning.rmf_wgs84 import TangentPlane
from tests.buildings.console import console_ok
from tests.buildings.rmf_clinic import clinic_level
from tests.planning.rmf_buildings import Level, Placing, Point

STOCKHOLM = (18.06, 59.33)  # longitude, latitude: where the clinic's middle is put
# SWEREF 99 TM, Sweden's grid, as a Swedish user's traffic-editor map names it for RMF's
# generator; the importer reads neither it nor the offsets (its frame is its own).
PARAMETERS = ("parameters: {generate_crs: [1, \"EPSG:3006\"], suggested_offset_x: [3, 674000], "
              "suggested_offset_y: [3, 6580000]}")  # fmt: skip


def middle(*levels: Level) -> Point:
    """The median design x and y of the levels' vertices as written (after the walls,
    doors and measurement corners have made theirs)."""
    for level in levels:
        level.yaml("cartesian_meters", walls=True)  # makes every vertex
    vertices = [vertex for level in levels for vertex in level.vertices]
    return (statistics.median(v[0] for v in vertices),
            statistics.median(v[1] for v in vertices))  # fmt: skip


def placing(centre: Point) -> Placing:
    """Design metres to longitude and latitude, `centre` at STOCKHOLM."""
    plane = TangentPlane(*STOCKHOLM)
    return lambda x, y: degrees(plane, x - centre[0], y - centre[1])


def degrees(plane: TangentPlane, east: float, north: float) -> tuple[float, float]:
    """The longitude and latitude whose point on `plane` is (`east`, `north`) metres."""
    lon, lat = plane.longitude, plane.latitude
    step = 1e-5  # degrees, for the slopes
    e0, n0 = plane.metres(lon, lat)
    de = (plane.metres(lon + step, lat)[0] - e0) / step  # metres a degree of longitude
    dn = (plane.metres(lon, lat + step)[1] - n0) / step  # metres a degree of latitude
    for _ in range(20):
        e, n = plane.metres(lon, lat)
        if math.hypot(east - e, north - n) < 1e-7:  # ECEF doubles: ~1e-9 m
            return lon, lat
        lon, lat = lon + (east - e) / de, lat + (north - n) / dn
    raise ArithmeticError(f"({east}, {north}) m did not converge to degrees")


def clinic_wgs84_text() -> tuple[str, Point]:
    """The clinic as a wgs84 `.building.yaml`'s text, and its middle in design metres."""
    level = clinic_level()
    centre = middle(level)
    body = level.yaml("wgs84", walls=True, place=placing(centre))
    text = ["coordinate_system: wgs84", "levels:", "  L1:", body, "name: clinic",
            PARAMETERS, ""]  # fmt: skip
    return "\n".join(text), centre


def clinic_pixels_text() -> str:
    """The clinic as a `reference_image` `.building.yaml`: drawing pixels, row 0 at the
    top, measured (rmf_buildings.SCALE_M a pixel; its map frame is design y less
    rmf_buildings.HEIGHT_M)."""
    body = clinic_level().yaml("reference_image", walls=True)
    return "\n".join(["coordinate_system: reference_image", "levels:", "  L1:", body,
                      "name: clinic", ""])  # fmt: skip


def rmf_clinic_wgs84(folder: Path) -> Path:
    """The wgs84 clinic's `.building.yaml` written into `folder` and imported beside it
    with the console; the plan's path (its grid, `clinic.pgm`, next to it)."""
    source = folder / "clinic.building.yaml"
    source.write_text(clinic_wgs84_text()[0])
    plan = folder / "clinic.yaml"
    console_ok("floorplan", "import", str(source), str(plan), "--level", "L1",
               "--name", "Clinic, ground floor", "--force")  # fmt: skip
    return plan
