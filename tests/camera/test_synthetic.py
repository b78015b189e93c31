"""The synthetic camera: the simulated world seen from the robot's true pose."""

from __future__ import annotations

import math

import cv2
import numpy as np

from giraff_console.sim.camera import WorldCamera
from giraff_console.sim.drive import TruePose
from giraff_console.sim.world import demo_world

CAMERA = WorldCamera(demo_world())


def test_the_same_pose_gives_the_same_image():
    pose = TruePose(1.0, 0.5, 0.3)
    first = CAMERA.render(pose, 320, 240)
    assert first.shape == (240, 320, 3) and first.dtype == np.uint8
    assert np.array_equal(first, CAMERA.render(pose, 320, 240))


def test_the_view_moves_and_turns_with_the_robot():
    start = CAMERA.render(TruePose(0, 0, 0), 320, 240)
    ahead = CAMERA.render(TruePose(1.0, 0, 0), 320, 240)
    turned = CAMERA.render(TruePose(0, 0, math.radians(30)), 320, 240)
    assert np.mean(start != ahead) > 0.05
    assert np.mean(start != turned) > 0.05


def test_closer_walls_look_taller():
    def wall_rows(x: float) -> int:
        image = CAMERA.render(TruePose(x, 0, 0), 160, 240)
        column = image[:, 80].astype(int)
        ceiling, floor_top = column[0], column[-1]
        return int(np.sum(np.any(column != ceiling, axis=1) & np.any(column != floor_top, axis=1)))

    assert wall_rows(4.0) > wall_rows(0.0)


def test_fast_finds_the_posters_corners():
    # Facing the poster on the north wall of the first room.
    image = CAMERA.render(TruePose(3.4, 0.0, math.radians(90)), 800, 600)
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    assert len(cv2.FastFeatureDetector_create(50).detect(grey)) >= 20
