"""The console's own commands, run in this process as a user types them, for building the
test buildings: an import or a segmentation is the user's way in, so the buildings are
made through it rather than by calling the modules behind it."""

from __future__ import annotations

import contextlib
import io
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from giraff_console.cli.main import main


class BuildingError(RuntimeError):
    """A console command refused to make a test building: the command and what it said."""


@dataclass(frozen=True)
class Said:
    """What a command did: its exit code and what it printed."""

    code: int
    out: str
    err: str


def console(*args: str) -> Said:
    """`giraff-console ARGS`, in this process; its exit code and output."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return Said(code, out.getvalue(), err.getvalue())


def console_ok(*args: str) -> Said:
    """`giraff-console ARGS`; BuildingError, with what it printed, unless it exits 0."""
    said = console(*args)
    if said.code != 0:
        raise BuildingError(f"giraff-console {' '.join(args)} exited {said.code}:\n"
                            f"{said.out}{said.err}")  # fmt: skip
    return said


@dataclass(frozen=True)
class Markers:
    """How `floorplan landmarks` went on a plan: the markers it placed, or None and why
    not (before issue 25, a plan without outlines had no walls to hang them on)."""

    placed: int | None
    said: str


_PLACED = re.compile(r"placed (\d+) markers?")
# Seconds to place a building's markers: a few on an idle machine.
MARKERS_TIMEOUT_S = 300


def put_up_markers(plan: Path) -> Markers:
    """`giraff-console floorplan landmarks PLAN`: the markers written into PLAN, or why
    not; never an exception, so that a benchmark can report it and go on. In a process
    of its own, so that a crash in the command (or a hang) is reported as one too."""
    command = [sys.executable, "-m", "giraff_console", "floorplan", "landmarks", str(plan)]
    try:
        done = subprocess.run(command, capture_output=True, text=True,
                              timeout=MARKERS_TIMEOUT_S)  # fmt: skip
    except subprocess.TimeoutExpired:
        return Markers(None, f"no answer in {MARKERS_TIMEOUT_S} s")
    text = (done.stdout + done.stderr).strip()
    if done.returncode != 0:
        last = text.splitlines()[-1] if text else ""
        return Markers(None, f"exit {done.returncode}: {last}")
    found = _PLACED.search(text)
    return Markers(int(found.group(1)) if found else 0, text)
