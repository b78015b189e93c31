"""The modem-line shim: lets an unchanged C or C++ driver open `giraff-console sim --pty`.

A pseudo-terminal has no modem-control lines, and drivers that set DTR/RTS with ioctls
before anything else (both open-source Giraff drivers do: wire-facts, "Opening the
port") fail on it with "Inappropriate ioctl for device". `modem_shim.c`, shipped with
the package, wraps ioctl() for such a program through LD_PRELOAD (see its header).

The library is built on first use with the system's C compiler, into the user's cache
folder, and named after a hash of its source, so a changed source is built afresh and
an unchanged one never again. `python -m giraff_console.sim.modem_shim` prints its path.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
from importlib.resources import files
from pathlib import Path

APP = "giraff-console"
SOURCE = "modem_shim.c"
COMPILERS = ("cc", "gcc", "clang")
# A compiler that takes longer than this on one small file has hung.
BUILD_TIMEOUT_S = 120.0
INSTALL_HINT = (
    "install one (Debian or Ubuntu: sudo apt install build-essential; Fedora: "
    "sudo dnf install gcc; Alpine: apk add build-base), or name it in $CC"
)


class ShimError(Exception):
    """The shim cannot be had here: not Linux, no C compiler, or the build failed."""


def cache_home() -> Path:
    """`$XDG_CACHE_HOME/giraff-console`, or `~/.cache/giraff-console` without it."""
    # The XDG spec says a relative XDG_CACHE_HOME is invalid and must be ignored.
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / APP


def shim_path() -> Path:
    """The built shim library, for LD_PRELOAD; built first if this source never was.

    ShimError when it cannot be built, saying what to install.
    """
    if not sys.platform.startswith("linux"):
        raise ShimError(
            "the modem shim is for Linux only: it recognises pseudo-terminals by their "
            "Linux device numbers"
        )
    source = (files("giraff_console.sim") / SOURCE).read_bytes()
    digest = hashlib.sha256(source).hexdigest()[:16]
    # The machine is in the name too: a home folder shared between an x86 laptop and
    # an ARM robot must not hand one the other's library.
    target = cache_home() / f"modem-shim-{platform.machine()}-{digest}.so"
    if not target.is_file():
        build(source, target)
    return target


def build(source: bytes, target: Path) -> None:
    """Compile `source` into the shared library `target`, atomically."""
    compiler = c_compiler()
    # Owner-only, as XDG asks of the cache: whoever can write here chooses the code
    # that runs inside the driver.
    target.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent, prefix=".build-") as work:
        c_file = Path(work) / SOURCE
        c_file.write_bytes(source)
        built = Path(work) / target.name
        # -ldl: dlsym lives in libdl before glibc 2.34 (an empty stub after it).
        command = [*compiler, "-shared", "-fPIC", "-O2", "-o", str(built), str(c_file), "-ldl"]
        try:
            result = subprocess.run(
                command, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S
            )
        except subprocess.TimeoutExpired as error:
            raise ShimError(f"{compiler[0]} did not finish building the modem shim") from error
        if result.returncode != 0:
            raise ShimError(
                f"{shlex.join(command)} failed (are the C library headers installed? "
                f"Debian or Ubuntu: libc6-dev):\n{result.stderr.strip()}"
            )
        # A program starting meanwhile, or a second build racing this one, sees either
        # no library or a whole one, never half of one.
        os.replace(built, target)


def c_compiler() -> list[str]:
    """$CC if set, else the first of cc, gcc, clang on the PATH; ShimError if none."""
    named = shlex.split(os.environ.get("CC", ""))
    if named:
        if shutil.which(named[0]) is None:
            raise ShimError(f"$CC is {named[0]!r}, which is not found: {INSTALL_HINT}")
        return named
    for name in COMPILERS:
        found = shutil.which(name)
        if found is not None:
            return [found]
    raise ShimError(
        f"building the modem shim needs a C compiler and none was found "
        f"({', '.join(COMPILERS)} on the PATH): {INSTALL_HINT}"
    )


def main() -> int:
    """Print the shim's path (building it first if need be); 1 with the reason if not."""
    try:
        path = shim_path()
    except (ShimError, OSError) as error:
        print(f"giraff-console: {error}", file=sys.stderr)
        return 1
    print(path, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
