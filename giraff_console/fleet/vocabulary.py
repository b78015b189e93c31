"""VDA 5050's words that both ends use: the vehicle writes them (fleet/state_report.py)
and a master control reads them (fleet/vehicle_report.py), as one set of types."""

from __future__ import annotations

import enum


class ConnectionState(enum.Enum):
    """`connection.connectionState` (§6.14): ONLINE and OFFLINE are the vehicle's own
    words; CONNECTIONBROKEN is its last will, said by the broker when the vehicle went
    without a goodbye (killed, powered off, out of the network)."""

    ONLINE = "ONLINE"
    OFFLINE = "OFFLINE"
    CONNECTIONBROKEN = "CONNECTIONBROKEN"


class OperatingMode(enum.Enum):
    """`state.operatingMode`: the robot says MANUAL while a person drives it by hand and
    AUTOMATIC otherwise; the others are the standard's, for other vehicles."""

    AUTOMATIC = "AUTOMATIC"
    SEMIAUTOMATIC = "SEMIAUTOMATIC"
    MANUAL = "MANUAL"
    SERVICE = "SERVICE"
    TEACHIN = "TEACHIN"


class ErrorLevel(enum.Enum):
    WARNING = "WARNING"
    FATAL = "FATAL"


class ActionStatus(enum.Enum):
    """`actionStates[].actionStatus` (2.1 has no PAUSED)."""

    WAITING = "WAITING"
    INITIALIZING = "INITIALIZING"
    RUNNING = "RUNNING"
    FINISHED = "FINISHED"
    FAILED = "FAILED"


class ActionType(enum.Enum):
    """The instant actions this vehicle takes (§6.8; its factsheet lists them)."""

    CANCEL_ORDER = "cancelOrder"
    START_PAUSE = "startPause"
    STOP_PAUSE = "stopPause"
    START_CHARGING = "startCharging"
    STOP_CHARGING = "stopCharging"
    INIT_POSITION = "initPosition"
    STATE_REQUEST = "stateRequest"
    FACTSHEET_REQUEST = "factsheetRequest"
