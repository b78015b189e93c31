"""Where the daemon's socket lives: a folder that only the user who runs it controls.

Whoever can connect to the socket can drive the robot, and whoever controls its folder
can put a socket of their own in its place for a front end to send its commands to.
So the folder must be ours and closed to everyone else before anything goes in it.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from giraff_console.service.transport import TransportError

SOCKET_NAME = "robot.sock"


def runtime_folder() -> Path:
    """`$XDG_RUNTIME_DIR/giraff-console/`, or `/tmp/giraff-console-<uid>/` without one;
    created private (0700), tightened to it if looser. TransportError if it is not a
    folder of our own."""
    base = os.environ.get("XDG_RUNTIME_DIR", "")
    # The XDG base directory spec: a relative path is invalid and is to be ignored.
    if base and os.path.isabs(base):
        folder = Path(base) / "giraff-console"
    else:
        folder = Path(f"/tmp/giraff-console-{os.getuid()}")
    return _private_folder(folder)


def socket_path(folder: Path | None = None) -> Path:
    """Where the daemon listens: robot.sock in `folder`, by default the runtime folder."""
    return (folder if folder is not None else runtime_folder()) / SOCKET_NAME


def _private_folder(folder: Path) -> Path:
    try:
        # Created 0700 (the umask can only narrow it), so never open even for a moment.
        os.mkdir(folder, 0o700)
    except FileExistsError:
        pass
    except OSError as error:
        raise TransportError(f"cannot create {folder}: {error.strerror or error}") from None
    # lstat: in /tmp, a symlink another user planted would lead to a folder they control.
    info = os.lstat(folder)
    if not stat.S_ISDIR(info.st_mode):
        raise TransportError(f"{folder} is not a folder (a symlink or a file?): not using it")
    if info.st_uid != os.getuid():
        raise TransportError(
            f"{folder} belongs to another user (uid {info.st_uid}): not using it; "
            "remove it, or set XDG_RUNTIME_DIR"
        )
    if stat.S_IMODE(info.st_mode) != 0o700:
        os.chmod(folder, 0o700)
    return folder
