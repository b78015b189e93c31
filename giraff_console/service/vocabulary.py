"""The words the robot service speaks in: the data its events and requests are made of.

A front end holds the service and nothing else (design.md, "The shape"; issue 26): it
takes these types from here, not from the layers below that define them, so that what
it may know of the robot is what the service says, the same in its own process and
across the daemon's socket.
"""

from giraff_console.link import Exchange, MotorState
from giraff_console.protocol.charger import ChargeStatus
from giraff_console.robot.battery import Battery
from giraff_console.robot.deadman import Intent
from giraff_console.robot.localisation import RECENT_S, Estimate, PoseBasis
from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.robot.mission import TEXT_BAR, MissionEnd, Outcome, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.stalk import head_height
from giraff_console.robot.telemetry import LinkState, Telemetry

__all__ = [
    "RECENT_S", "TEXT_BAR", "Battery", "ChargeStatus", "Estimate", "Exchange", "Intent",
    "LinkState", "MissionChanged", "MissionEnd", "MotorState", "Note", "Outcome", "Pose",
    "PoseBasis", "Progress", "Telemetry", "head_height",
]  # fmt: skip
