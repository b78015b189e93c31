"""The planners' defaults, apart from numpy, OpenCV and scipy: the command line shows
them in `--help`, which must not pay for loading those (issue 26, item 6). The modules
that use them take them from here.
"""

from __future__ import annotations

from giraff_console.protocol.kinematics import BODY_RADIUS_M

# The robot's radius that the walls are grown by (route_planner.py).
ROBOT_RADIUS_M = BODY_RADIUS_M
# Less floor than this is a cupboard, a bay window or noise, not a room to send a robot
# to (room_segmentation.py).
MIN_ROOM_M2 = 1.0
# Metres between the markers placed along a long wall (landmark_placement.py).
DEFAULT_EVERY_M = 4.0
# The markers' family when a plan names none: OpenCV's DICT_APRILTAG_36h11 (landmarks.py).
DEFAULT_FAMILY = "apriltag_36h11"
