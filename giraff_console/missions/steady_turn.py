"""The pose a path mission's turns on the spot are steered by, when markers correct it.

Markers seen during a turn on the spot move the estimate a little at every frame, and a
turn steered by it chases each move and never comes to rest. A turn is steered instead
by the estimate as it began, turned since by the odometry, which a turn on the spot
measures well (§3.2.1.3); what the markers corrected meanwhile, the drive after it
steers out.
"""

from __future__ import annotations

from giraff_console.motion.executor import Executor
from giraff_console.motion.path import Rotation
from giraff_console.robot.odometry import Pose


class SteadyTurn:
    """Follows one executor's turns on the spot; see the module docstring."""

    def __init__(self) -> None:
        # The turn under way, the estimate as it began and the odometry's heading then.
        self._turn: tuple[Rotation, Pose, float] | None = None

    def pose(self, executor: Executor, estimate: Pose, odometry: Pose) -> Pose:
        """What `executor` steers by: `estimate` while it drives, else the turn's."""
        section = None if executor.finished else executor.sections[executor.index]
        if not isinstance(section, Rotation):
            self._turn = None
            return estimate
        if self._turn is None or self._turn[0] is not section:
            self._turn = (section, estimate, odometry.heading)
        _, began, heading_then = self._turn
        return Pose(began.x, began.y, began.heading + odometry.heading - heading_then)
