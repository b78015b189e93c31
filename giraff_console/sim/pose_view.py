"""The synthetic camera's picture, drawn again only when what it shows has changed.

A simulated robot standing still sees exactly the same picture frame after frame, and
drawing it is most of what the synthetic camera costs (tens of milliseconds at
800x600, bench/camera.py): ten times a second, a fifth of a core for nothing (issue
26). So the last picture is given again, the same array, until the robot's true pose,
the picture's size or the surroundings (a box put down, a door shut) change. The
array is read-only, since every reader shares it; a reader can tell a repeated picture
by its identity (camera/feed.py then neither processes nor draws it again).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose


class PoseView:
    """`camera`'s picture from the pose `pose()` gives now, as a SyntheticCamera renders
    (`view(width, height)`); `drawings` counts the pictures really drawn."""

    def __init__(self, camera: WorldCamera, pose: Callable[[], TruePose]) -> None:
        self.camera = camera
        self.pose = pose
        self.drawings = 0
        self._drawn_for: tuple[TruePose, int, int, int | None] | None = None
        self._picture: np.ndarray | None = None

    def __call__(self, width: int, height: int) -> np.ndarray:
        pose = self.pose()
        surroundings = self.camera.surroundings
        # The surroundings' revision moves on with every box and door (sim/surroundings.py).
        revision = surroundings.snapshot().revision if surroundings is not None else None
        drawn_for = (pose, width, height, revision)
        if self._picture is None or drawn_for != self._drawn_for:
            picture = self.camera.render(pose, width, height)
            picture.flags.writeable = False
            self._picture, self._drawn_for = picture, drawn_for
            self.drawings += 1
        return self._picture
