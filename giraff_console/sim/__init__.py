"""A faithful Giraff motor board on the other end of the wire (§3.2.2, B.2).

The simulator speaks only bytes: reach it in-process through pyserial as
`serial.serial_for_url("giraff-sim://...")`, or from any program through
`giraff-console sim --pty`. It knows nothing of the console.

The names below are imported on first use (PEP 562), not with the package: the
firmware table (firmware.py), which the command line's `--help` lists, must not pay
for the board and numpy (issue 26, item 6).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from giraff_console.sim.board import BoardConfig, GiraffBoard
    from giraff_console.sim.drive import MoveParams, Style, TruePose
    from giraff_console.sim.firmware import DEFAULT_FIRMWARE, FIRMWARES, Firmware
    from giraff_console.sim.head import HOME_TILT, HomingState
    from giraff_console.sim.imperfections import Imperfections
    from giraff_console.sim.pty_server import PtyServer

# Where each name of the package lives.
_MODULES = {
    "giraff_console.sim.board": ("BoardConfig", "GiraffBoard"),
    "giraff_console.sim.drive": ("MoveParams", "Style", "TruePose"),
    "giraff_console.sim.firmware": ("DEFAULT_FIRMWARE", "FIRMWARES", "Firmware"),
    "giraff_console.sim.head": ("HOME_TILT", "HomingState"),
    "giraff_console.sim.imperfections": ("Imperfections",),
    "giraff_console.sim.pty_server": ("PtyServer",),
}
_HOME = {name: module for module, names in _MODULES.items() for name in names}


def __getattr__(name: str) -> object:
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOME[name]), name)
    globals()[name] = value  # found directly from now on
    return value


__all__ = [
    "DEFAULT_FIRMWARE",
    "FIRMWARES",
    "HOME_TILT",
    "BoardConfig",
    "Firmware",
    "GiraffBoard",
    "HomingState",
    "Imperfections",
    "MoveParams",
    "PtyServer",
    "Style",
    "TruePose",
]
