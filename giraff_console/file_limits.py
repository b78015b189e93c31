"""How large a file of each kind the console will read, and how many things in it (issue 30).

A robot's small PC has 2-4 GB. A file that would need more than the limits here (a
"billion laughs" YAML, a grid image whose header claims 100,000 x 100,000 pixels, a plan
with 100,000 markers, a symlink to /dev/zero) is refused before anything large is
allocated, with the usual `file:line` message.

The defaults are generous for real buildings: an airport terminal of 300 x 150 m at
0.05 m a cell is a 6000 x 3000 grid (18 million cells), well inside them. A site with a
larger building raises them in the settings file's `[limits]` table (settings.py); the
process reads its limits once at start (`use`) and every reader asks `current()`.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FileLimits:
    """The largest input of each kind the console reads; every field a positive int."""

    # Bytes of any one file read whole (YAML, JSON, TOML, PGM, PNG, control logs' lines
    # are bounded apart): the airport's PGM is 18 MB.
    file_bytes: int = 64 * 1024 * 1024
    # Pixels of a grid image, read from its header before decoding: 300 x 150 m at
    # 0.05 m is 18 million; a 12000 x 12000 image would need 4 GB to plan on.
    image_pixels: int = 40_000_000
    # Nodes of a YAML document counted with its aliases expanded, as the readers walk it.
    yaml_nodes: int = 2_000_000
    # Things in a building: rooms, doors, markers; and in a route or patrol, its points.
    rooms: int = 5_000
    doors: int = 20_000
    markers: int = 10_000
    waypoints: int = 100_000


_current = FileLimits()


def current() -> FileLimits:
    """The limits this process reads by."""
    return _current


def use(limits: FileLimits) -> None:
    """Read by these from now on (the settings' `[limits]`, once at start)."""
    global _current
    _current = limits
