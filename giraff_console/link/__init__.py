"""A Giraff motor board over any pyserial port: handshake, request/response, timeouts."""

from giraff_console.link.board_link import DEFAULT_TIMEOUT_S, HANDSHAKE_TIMEOUT_S, BoardLink
from giraff_console.link.board_probe import BoardFeatures, probe
from giraff_console.link.errors import LinkDisconnected, LinkError, LinkTimeout
from giraff_console.link.exchange import Exchange, Observer
from giraff_console.link.motor_state import MotorState

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "HANDSHAKE_TIMEOUT_S",
    "BoardFeatures",
    "BoardLink",
    "Exchange",
    "LinkDisconnected",
    "LinkError",
    "LinkTimeout",
    "MotorState",
    "Observer",
    "probe",
]
