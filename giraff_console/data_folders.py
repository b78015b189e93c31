"""Where the console's files live by default, so that it works from any folder.

- The example floor plan ships inside the package (`giraff_console/floorplans/`) and is
  found with importlib.resources, wherever the package was installed; so do the example
  patrols for it (`giraff_console/routes/`), looked for after the operator's routes
  folder, so that a patrol of the same name there comes first.
- The operator's recordings and taught routes live in the XDG data folder,
  `$XDG_DATA_HOME/giraff-console/` (usually `~/.local/share/giraff-console/`), not in
  whatever folder the console happens to be started from. The command line
  (`--recordings`, `--routes`) comes first, then the settings file's `recordings` and
  `routes` keys, then these defaults.
"""

from __future__ import annotations

import contextlib
import os
from importlib.resources import files
from pathlib import Path

from giraff_console.private_files import private_folder

APP = "giraff-console"


def example_floorplan() -> Path:
    """The example care home that ships with the package.

    A real path, not a Traversable: the loader finds the plan's grid image next to it.
    Wheels are installed unpacked, so the package's files are always on disk.
    """
    return Path(str(files("giraff_console") / "floorplans" / "care-home.yaml"))


def example_routes() -> Path:
    """The folder of the example patrols (and any routes they drive) that ship with the
    package, for the example floor plan: `patrol night` runs from a fresh install."""
    return Path(str(files("giraff_console") / "routes"))


def config_path() -> Path:
    """The settings file (settings.py reads it): here, apart from what reads it, so that
    `--help` can name it without loading the robot's defaults (issue 26, item 6)."""
    base = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    return Path(base) / APP / "config.toml"


def data_home() -> Path:
    """`$XDG_DATA_HOME/giraff-console`, or `~/.local/share/giraff-console` without it."""
    # The XDG spec says a relative XDG_DATA_HOME is invalid and must be ignored.
    base = os.environ.get("XDG_DATA_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".local", "share")
    return Path(base) / APP


def patrol_runs() -> Path:
    """Where each patrol's run is logged (missions/patrol_log.py): the data home's
    `patrol-runs`, which `giraff-console patrols` lists."""
    return data_home() / "patrol-runs"


def default_recordings() -> Path:
    return data_home() / "recordings"


def default_routes() -> Path:
    return data_home() / "routes"


def data_folder(given: Path | None, configured: str | None, default: Path) -> Path:
    """The folder to use: `given` on the command line, else `configured` in the
    settings file, else `default`, whose parent is made owner-only here.

    `default` itself is made on first use (the first recording, the first route
    saved), inside the private parent: sessions hold camera video of residents and
    staff, and only the operator may read them.
    """
    if given is not None:
        return given
    if configured is not None:
        return Path(configured)
    # A folder that cannot be made (a read-only home) is not fatal here: recording or
    # saving a route reports it when it is tried, and driving goes on.
    with contextlib.suppress(OSError):
        private_folder(default.parent)
    return default
