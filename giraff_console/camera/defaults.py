"""The camera's defaults, apart from OpenCV and numpy: the command line shows them in
`--help`, which must not pay for loading those (issue 26, item 6). The modules that use
them (processors.py, feed.py, robot/marker_eye.py) take them from here.
"""

from __future__ import annotations

# FAST's threshold in the thesis (B.9).
FAST_THRESHOLD = 50
# Frames are taken at up to this many a second: about what the Giraff's camera delivers.
DEFAULT_FPS = 10.0
# The Giraff's camera delivers about 10 frames a second at 800x600 (§3.3).
EYE_FPS = 10.0
EYE_SIZE = (800, 600)
