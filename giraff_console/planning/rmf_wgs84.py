"""Geo-referenced Open-RMF building maps (`coordinate_system: wgs84`) in metres.

traffic-editor writes a wgs84 vertex as `[longitude, latitude, z, name, {parameters}]`:
degrees on the WGS 84 ellipsoid, longitude first, y not flipped (RMF's map generator
reads them so, and then projects them into the map's `generate_crs`, a national grid or
a UTM zone, whose scale factor and grid north differ from the ground's by up to 0.04 %
and a few degrees). A floor plan wants plain metres about the building, so the importer
projects every vertex onto the plane tangent to the ellipsoid at the building's middle:
x east, y north, in metres (the ENU frame of REP 105's local maps). The plane is exact
at the middle and shortens a point d metres away by d^3 / 6R^2, R ~ 6370 km: 4
micrometres at 1 km, 0.5 mm at the EXTENT_M allowed, so an import is true to the ground
to well under a millimetre across any building, with no series to truncate (a
transverse Mercator about the same point agrees with it to that order). The projection
is onto the ellipsoid's surface (a vertex's z and a level's elevation are not read: a
floor plan is flat), which a floor 100 m above it would read 16 ppm short, 0.6 mm over
40 m.

The middle is the median longitude and the median latitude of every level's vertices,
so that all the levels of one building share one frame, and one stray vertex cannot
move it. What cannot be a place in the building (a latitude beyond +-90, a longitude
beyond +-180, or a vertex further than EXTENT_M from the middle: pixels or metres from
another coordinate system, or longitude and latitude swapped) is a problem at its line.
"""

from __future__ import annotations

import math
import statistics
from typing import Any

from giraff_console.planning.floorplan import Point, Where, dotted
from giraff_console.planning.rmf_source import BuildingSource, is_number

# WGS 84's ellipsoid (NIMA TR8350.2, §3): semi-major axis and flattening.
_A_M = 6378137.0
_F = 1 / 298.257223563
_E2 = _F * (2 - _F)

EXTENT_M = 5000.0  # furthest a vertex may be from the building's middle: see above


def ecef(longitude: float, latitude: float) -> tuple[float, float, float]:
    """The point on the ellipsoid's surface at `longitude`, `latitude` (degrees), in
    earth-centred, earth-fixed metres."""
    lon, lat = math.radians(longitude), math.radians(latitude)
    across = _A_M / math.sqrt(1 - _E2 * math.sin(lat) ** 2)  # prime vertical radius
    return (across * math.cos(lat) * math.cos(lon), across * math.cos(lat) * math.sin(lon),
            across * (1 - _E2) * math.sin(lat))  # fmt: skip


class TangentPlane:
    """Metres east and north on the plane tangent to the ellipsoid at an origin."""

    def __init__(self, longitude: float, latitude: float) -> None:
        self.longitude, self.latitude = longitude, latitude
        self._centre = ecef(longitude, latitude)
        lon, lat = math.radians(longitude), math.radians(latitude)
        self._east = (-math.sin(lon), math.cos(lon), 0.0)
        self._north = (-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon),
                       math.cos(lat))  # fmt: skip

    def metres(self, longitude: float, latitude: float) -> Point:
        """(east, north) of the point at `longitude`, `latitude` (degrees)."""
        away = [p - c for p, c in zip(ecef(longitude, latitude), self._centre, strict=True)]
        east = sum(a * b for a, b in zip(away, self._east, strict=True))
        north = sum(a * b for a, b in zip(away, self._north, strict=True))
        return east, north

    def __str__(self) -> str:
        ns = "N" if self.latitude >= 0 else "S"
        ew = "E" if self.longitude >= 0 else "W"
        return f"{abs(self.latitude):.7f} {ns}, {abs(self.longitude):.7f} {ew}"


def on_earth(item: Any) -> bool:
    """Whether a vertex as written begins with a longitude and a latitude."""
    return (isinstance(item, list) and len(item) >= 2 and all(map(is_number, item[:2]))
            and -180 <= item[0] <= 180 and -90 <= item[1] <= 90)  # fmt: skip


def building_plane(levels: dict) -> TangentPlane | None:
    """The plane about the building's middle: the median longitude and latitude of
    every level's vertices that are places on earth; None if none is."""
    found = [item[:2] for level in levels.values() if isinstance(level, dict)
             and isinstance(level.get("vertices"), list)
             for item in level["vertices"] if on_earth(item)]  # fmt: skip
    if not found:
        return None
    return TangentPlane(statistics.median(p[0] for p in found),
                        statistics.median(p[1] for p in found))  # fmt: skip


def in_metres(
    source: BuildingSource, points: list[Point | None], levels: dict, where: Where
) -> tuple[list[Point | None], str]:
    """The level's vertices (longitude, latitude as read) in metres on the building's
    tangent plane, and the frame told; each vertex that cannot be in the building is a
    problem at its line, and None."""
    plane = building_plane(levels)
    located: list[Point | None] = []
    for i, point in enumerate(points):
        at = (*where, "vertices", i)
        if point is None:  # already a problem
            located.append(None)
            continue
        longitude, latitude = point
        if not on_earth([longitude, latitude]) or plane is None:
            source.add(at, f"{dotted(at)} should begin with a longitude from -180 to 180 and "
                       f"a latitude from -90 to 90 (coordinate_system wgs84), not "
                       f"[{longitude:g}, {latitude:g}]: pixels or metres?")  # fmt: skip
            located.append(None)
            continue
        metres = plane.metres(longitude, latitude)
        away = math.hypot(*metres)
        if away > EXTENT_M:
            source.add(at, f"{dotted(at)} [{longitude:g}, {latitude:g}] is {away / 1000:.1f} km "
                       f"from the building's middle ({plane}), more than "
                       f"{EXTENT_M / 1000:g} km: longitude and latitude swapped, or another "
                       "coordinate system's numbers?")  # fmt: skip
            located.append(None)
            continue
        located.append(metres)
    frame = f"wgs84: metres east and north of {plane}, on the plane tangent there"
    return located, frame
