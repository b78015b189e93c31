"""Names the missions give meaning to, apart from the missions themselves: the command
line shows them in `--help`, which must not pay for the planner, numpy and scipy that
docking.py and patrol.py load (issue 26, item 6).
"""

from __future__ import annotations

# What `go` takes to mean the dock rather than a room (docking.py).
DOCK = "dock"
# A patrol file's name ends so (patrol.py).
PATROL_SUFFIX = ".patrol.yaml"
