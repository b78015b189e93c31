"""What the control loop publishes after every tick, for the console to draw."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from giraff_console.link.motor_state import MotorState
from giraff_console.robot.deadman import Intent
from giraff_console.robot.odometry import Pose
from giraff_console.robot.replay import PlaybackStatus


class LinkState(enum.Enum):
    CONNECTED = "connected"
    LOST = "link lost"


@dataclass(frozen=True)
class Telemetry:
    """What the console shows, as of one control tick."""

    link: LinkState
    state: MotorState | None
    pose: Pose
    intent: Intent | None
    speed: float
    board_r: float | None
    autopoll: bool
    loop_hz: float
    late_ms: float
    playback: PlaybackStatus | None = None
    mission: str | None = None
