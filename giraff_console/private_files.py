"""Everything the robot writes is its owner's alone (issue 30): folders 0700, files 0600.

Sessions hold camera video of residents and staff, control logs say where the robot
went and when; routes, plans, maps and patrol logs draw the building and its habits. A
second user of the machine may read none of it, wherever the settings or the command
line put it. The program sets its umask to 0o077 as it starts (launch.py), which covers
every writer, OpenCV's VideoWriter and other libraries included; the writers here give
the modes themselves as well, so that what they make is private whatever the umask of
whoever calls them (a test, another program using the package).

A folder the operator made (`~/giraff/recordings` at 0755) keeps its mode: it is theirs,
and they may mean it to be shared; what is made inside it is private, so its listing
shows at most the names of sessions, never what is in them.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO, Any

PRIVATE_FOLDER = 0o700
PRIVATE_FILE = 0o600
# What the process's umask is set to at start: nothing for the group or others.
PRIVATE_UMASK = 0o077


def private_folder(path: Path) -> Path:
    """`path`, made if it is not there, and every folder made on the way to it made
    owner-only (Path.mkdir gives its parents the umask's mode); folders already there
    keep theirs. FileExistsError if it is there and not a folder."""
    missing = []
    for folder in (path, *path.parents):
        if folder.is_dir():
            break
        missing.append(folder)
    for folder in reversed(missing):
        try:
            # The umask can only narrow 0700, so the folder is never open, even for a moment.
            os.mkdir(folder, PRIVATE_FOLDER)
        except FileExistsError:
            if not folder.is_dir():
                raise  # a file in the way: the caller says so
    return path


def open_private(path: Path, mode: str = "w", **options: Any) -> IO[Any]:
    """`open(path, mode)` for writing ("w", "wb", "a", "ab", "x", "xb"), the file
    owner-only from its first byte: one already there is made so before it is written."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC
    if "x" in mode:
        flags |= os.O_EXCL
    flags |= os.O_APPEND if "a" in mode else os.O_TRUNC
    descriptor = os.open(path, flags, PRIVATE_FILE)
    try:
        os.fchmod(descriptor, PRIVATE_FILE)
        return os.fdopen(descriptor, mode.replace("x", "w"), **options)
    except BaseException:
        os.close(descriptor)
        raise


def write_private(path: Path, data: bytes) -> None:
    """Write `data` to `path`, owner-only, as Path.write_bytes would."""
    with open_private(path, "wb") as file:
        file.write(data)


def make_private(path: Path) -> None:
    """Narrow a file a library made (OpenCV's video, a temporary file) to owner-only."""
    os.chmod(path, PRIVATE_FOLDER if path.is_dir() else PRIVATE_FILE)
