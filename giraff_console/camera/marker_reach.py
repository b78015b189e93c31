"""How far off a printed marker the camera still reads it, and still trusts its slant.

A marker's black square, `size` metres a side, is FOCAL_PX * size / d pixels wide at d
metres. What the robot can do with it depends on that width, not on the metres: a
marker printed half as large again is read half as far again. So every reach that
missions and the pose filter act on is a reach in pixels turned into metres for the
plan's own size (`floorplan landmarks` chooses one that every room's stop can read,
planning/landmark_placement.py).
"""

from __future__ import annotations

# The Giraff's camera sees 90 degrees across (sim/camera.py) on an 800-pixel frame
# (camera/source.py's default): a focal length of 400 pixels.
FOCAL_PX = 400.0
# Narrower than this a marker is not decoded: two pixels a cell of AprilTag 36h11's
# eight (its 6 by 6 bits and their black border); 16 cm at 4 m.
READ_PX = 16.0
# Narrower than this a marker's facing, from the slant of its square, is not used to
# correct the pose, only its distance and bearing: a few pixels' slant bias it the same
# way frame after frame, which the filter cannot average out (issue 25: a robot 5 m
# from the day room's walls was put 10 cm off, and believed itself within 4 cm).
# 16 cm at 3 m.
FACING_PX = 21.0
# The size a marker is printed at unless the plan says otherwise: its page fits A3.
STANDARD_SIZE_M = 0.16


def read_reach(size: float) -> float:
    """How far off a marker `size` metres across is still decoded, metres."""
    return FOCAL_PX * size / READ_PX


def facing_reach(size: float) -> float:
    """How far off a marker `size` metres across still gives its facing, metres."""
    return FOCAL_PX * size / FACING_PX


def least_size(distance: float, pixels: float) -> float:
    """The least size of marker that is `pixels` wide `distance` metres off (READ_PX to
    be decoded, FACING_PX to give its facing)."""
    return distance * pixels / FOCAL_PX
