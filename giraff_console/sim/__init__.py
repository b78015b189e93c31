"""A faithful Giraff motor board on the other end of the wire (§3.2.2, B.2).

The simulator speaks only bytes: reach it in-process through pyserial as
`serial.serial_for_url("giraff-sim://...")`, or from any program through
`giraff-console sim --pty`. It knows nothing of the console.
"""

from giraff_console.sim.board import BoardConfig, GiraffBoard
from giraff_console.sim.drive import MoveParams, Style, TruePose
from giraff_console.sim.firmware import DEFAULT_FIRMWARE, FIRMWARES, Firmware
from giraff_console.sim.head import HOME_TILT, HomingState
from giraff_console.sim.imperfections import Imperfections
from giraff_console.sim.pty_server import PtyServer

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
