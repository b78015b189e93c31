"""The files a command is to write, checked before it writes any of them.

A command that writes several files (`floorplan rooms`: a floor plan, its grid image and
a picture) writes all of them or none: one that fails half-way leaves files behind that
look like a result, and a message about the wrong one. So every output is checked
first: its folder must be there and writable, it must not be a folder itself, two
outputs must not be one file, and one that exists is overwritten only with `force`.
Nor may an output be one of the command's inputs, `force` or not: `--force` is for an
old result, not for the map the result is made from.
"""

from __future__ import annotations

import os
from pathlib import Path


class OutputError(ValueError):
    """An output that must not be written; the message says which and why, in one line."""


def check_outputs(
    outputs: list[tuple[str, Path]], inputs: list[tuple[str, Path]], force: bool
) -> None:
    """Raise OutputError for the first of `outputs` that cannot or must not be written;
    each output and input is (what it is to the user, its path): ("OUT", plan.yaml)."""
    for number, (what, path) in enumerate(outputs):
        for other, source in inputs:
            if _same(path, source):
                raise OutputError(f"{what} {path} would overwrite {other} {source}: "
                                  "choose another name")  # fmt: skip
        for other, earlier in outputs[:number]:
            if _same(path, earlier):
                raise OutputError(f"{what} {path} is {other} too: choose another name")
        folder = path.parent
        if not folder.is_dir():
            raise OutputError(f"{what} {path}: there is no folder {folder} to write it in")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OutputError(f"{what} {path}: the folder {folder} cannot be written in")
        if path.is_dir():
            raise OutputError(f"{what} {path} is a folder: give a file's name")
        if path.exists() and not force:
            raise OutputError(f"{path} exists: --force overwrites it")


def _same(a: Path, b: Path) -> bool:
    """Whether two paths are one file: by their real paths (symbolic links followed), or
    for files that exist, as the system sees them (hard links too)."""
    if a.resolve() == b.resolve():
        return True
    try:
        return a.samefile(b)
    except OSError:  # either is missing: the real paths said all there is
        return False
