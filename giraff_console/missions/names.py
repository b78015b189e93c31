"""Names the missions give meaning to, apart from the missions themselves: the command
line shows them in `--help`, which must not pay for the planner, numpy and scipy that
docking.py and patrol.py load (issue 26, item 6).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

# What `go` takes to mean the dock rather than a room (docking.py).
DOCK = "dock"
# A patrol file's name ends so (patrol.py).
PATROL_SUFFIX = ".patrol.yaml"


def list_patrols(directory: Path) -> list[str]:
    """The names of the patrols in `directory`, sorted."""
    return sorted(
        path.name.removesuffix(PATROL_SUFFIX) for path in Path(directory).glob(f"*{PATROL_SUFFIX}")
    )


def patrol_file(name: str, folders: Sequence[Path]) -> Path:
    """The file of patrol `name`: `name` itself when it is a patrol file's path, else
    `NAME.patrol.yaml` in the first of `folders` that holds one (the operator's routes
    folder before the examples shipped with the package, so that the operator's own
    `night` is the one run). With none, the first folder's, for the error to name.
    The routes a patrol drives are looked for beside its file. An operator's file that
    is not a regular one (a FIFO, a link to a device) is still theirs, to be refused
    by the reader, not passed over for an example of the same name."""
    if name.endswith(PATROL_SUFFIX):
        return Path(name)
    candidates = [Path(folder) / f"{name}{PATROL_SUFFIX}" for folder in folders]
    return next((path for path in candidates if path.exists()), candidates[0])
