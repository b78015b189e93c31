"""How large a file of each kind the console will read, and how many things in it (issue 30).

A robot's small PC has 2-4 GB. A file that would need more than the limits here (a
"billion laughs" YAML, a grid image whose header claims 100,000 x 100,000 pixels, a plan
with 100,000 markers, a symlink to /dev/zero) is refused before anything large is
allocated, with the usual `file:line` message; docs/limits.md says each limit and why.

The defaults are generous for real buildings: an airport terminal of 300 x 150 m at
0.05 m a cell is a 6000 x 3000 grid (18 million cells), well inside them. A site with a
larger building raises them in the settings file's `[limits]` table (settings.py); the
process reads its limits once at start (`use`) and every reader asks `current()`.

Every file the console reads whole goes through `read_bounded`, and every file it hands
to another library by name (a video to OpenCV) through `regular_file`: a FIFO would block
the open itself, and a device (/dev/zero, /dev/urandom) never ends, whatever size it gives.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

_MIB = 1024 * 1024


@dataclass(frozen=True)
class FileLimits:
    """The largest input of each kind the console reads; every field a positive int, its
    name the key that raises it in the settings file's `[limits]` table."""

    # Bytes of a document read whole: YAML (plans, maps, routes, patrols, calibrations,
    # Open-RMF buildings), JSON (meta.json), TOML (settings). The largest real plan we
    # know, a building of 10,000 markers, is under 1 MB; parsing takes ~20 times its size.
    file_bytes: int = 16 * _MIB
    # Bytes of a grid image (PGM or PNG): the airport's PGM is 18 MB.
    image_bytes: int = 128 * _MIB
    # Bytes of a recording's logs (control.log, estimates, the frames' index): an hour of
    # control.log is about 11 MB (the sample's 29 kB in 10 s), and playing one back holds
    # about 5 times its size.
    log_bytes: int = 64 * _MIB
    # Pixels of a grid image, read from its header before decoding: 300 x 150 m at
    # 0.05 m is 18 million. Planning takes about 29 bytes a cell (a 12000 x 12000 image
    # took 4.2 GB), so this many need some 730 MB.
    image_pixels: int = 25_000_000
    # Nodes of a YAML document counted with its aliases expanded, before it is built:
    # reading one (building it, finding the lines of its keys) takes about 800 bytes and
    # 12 microseconds a node, so this many need some 200 MB and 3 s. A plan of 10,000
    # markers is 130,000 nodes.
    yaml_nodes: int = 250_000
    # Things in a building: rooms, doors (two a room), markers; and in a route or patrol,
    # its points (a route samples its path every 0.1 m: 2 km of it).
    rooms: int = 5_000
    doors: int = 10_000
    markers: int = 10_000
    waypoints: int = 20_000


_current = FileLimits()

ByteLimit = Literal["file_bytes", "image_bytes", "log_bytes"]
CountLimit = Literal["rooms", "doors", "markers", "waypoints", "yaml_nodes", "image_pixels"]


def current() -> FileLimits:
    """The limits this process reads by."""
    return _current


def use(limits: FileLimits) -> None:
    """Read by these from now on (the settings' `[limits]`, once at start)."""
    global _current
    _current = limits


class FileRefused(OSError):
    """A file not read, by its type or its size; the message says why and, for a size,
    which setting raises the limit. An OSError, as a missing file is, so that every
    reader that reports one ("cannot read it: ...") reports the other."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message

    def __str__(self) -> str:
        return self.message


def too_many(count: int, limit: CountLimit, what: str) -> str | None:
    """The message for `count` of `what` beyond the limit named `limit`; None within it."""
    most = getattr(_current, limit)
    if count <= most:
        return None
    return f"{count:,} {what}, more than the {most:,} this console reads ({raising(limit)})"


def raising(limit: str) -> str:
    """How a site raises `limit`: the words every refusal ends with."""
    return f"raise it with {limit} in the settings file's [limits] table"


def regular_file(path: Path | str) -> os.stat_result:
    """The status of `path`, which must be a regular file (a link to one will do);
    FileRefused for a device, a FIFO, a socket or a folder, decided without opening it:
    opening a FIFO for reading blocks until a writer comes. OSError if there is none."""
    status = os.stat(path)  # follows links: a link to /dev/zero is a device
    if not stat.S_ISREG(status.st_mode):
        raise FileRefused(f"it is {_kind(status.st_mode)}, not a regular file")
    return status


def read_bounded(path: Path | str, limit: ByteLimit = "file_bytes") -> bytes:
    """The whole of the regular file `path`, if it holds no more bytes than the limit
    named `limit`; FileRefused if it is not a regular file or is larger (by its size, and
    by reading at most one byte more, should it grow while read); OSError if it cannot
    be read."""
    return read_at_most(path, getattr(_current, limit), f"this console reads ({raising(limit)})")


def read_at_most(path: Path | str, most: int, whose: str) -> bytes:
    """As read_bounded, by a bound of `most` bytes that no setting raises (the settings
    file's own, read before its [limits] are known); `whose` ends the refusal's "more
    than the N ..." ("a settings file may have")."""
    status = regular_file(path)
    if status.st_size > most:
        raise FileRefused(_larger(status.st_size, most, whose))
    # O_NONBLOCK: were it swapped for a FIFO since the stat, the open must not block.
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise FileRefused("it is not a regular file (it was replaced while read)")
        chunks, size = [], 0
        while size <= most:
            chunk = os.read(descriptor, min(most + 1 - size, _MIB))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    finally:
        os.close(descriptor)
    if size > most:
        raise FileRefused(_larger(size, most, whose))
    return b"".join(chunks)


def _larger(size: int, most: int, whose: str) -> str:
    return f"it holds {size:,} bytes, more than the {most:,} {whose}"


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "a special file"
