"""What the control loop publishes after every tick, for the console to draw."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from giraff_console.link.board_probe import BoardFeatures
from giraff_console.link.motor_state import MotorState
from giraff_console.robot.battery import Battery
from giraff_console.robot.deadman import Intent
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.mission import Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.replay import PlaybackStatus


class LinkState(enum.Enum):
    CONNECTED = "connected"
    LOST = "link lost"


@dataclass(frozen=True)
class Telemetry:
    """What the console shows, as of one control tick.

    `board` is what the probe found on the board connected (None while the link is
    lost); `battery` and `stalk` (the height setting `h`, 0..1000) are the latest
    readings of a later board, None until read or on a board without them.
    `pose` is where the robot is believed to be, `estimate.pose` (the pose filter's,
    robot/localisation.py); `estimate` says how well that is known and keeps the
    odometry's own pose beside it. During a playback both are the recording's.
    """

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
    mission: Progress | None = None  # the mission under way's
    battery: Battery | None = None
    stalk: int | None = None
    board: BoardFeatures | None = None
    estimate: Estimate | None = None
    # Whether a session is being recorded: the robot service's to say (the loop does
    # not know its listeners), filled in as the snapshot goes out to the front ends.
    recording: bool = False
    # The held keys' move is under way and the wheels have not turned (teleop.BLOCKED_S).
    blocked: bool = False
