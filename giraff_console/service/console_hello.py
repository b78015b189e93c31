"""What a console says first and how it asks: the two messages every client sends.

Apart from the daemon (daemon.py), which brings in most of the robot's types to tell the
consoles everything, so that a client that only asks (`giraff-console stop`,
stop_request.py) can say them without loading the rest (issue 30, item 3).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Annotated

from giraff_console.service import commands as c
from giraff_console.service import wire


@dataclass(frozen=True)
class Hello:
    """A console's first message: who it is, and whether it wants the controls."""

    console: Annotated[str, c.CONSOLE]
    take: bool = True


@dataclass(frozen=True)
class Asked:
    """A request, numbered so that its answer can be told apart."""

    number: int
    request: c.Request


def console_name(kind: str) -> str:
    """How other consoles see this one: what it is and where it runs (the SSH client's
    address, or the terminal)."""
    where = os.environ.get("SSH_CLIENT", "").split(" ")[0] or _terminal()
    return f"{kind} {where}".strip()


def _terminal() -> str:
    try:
        return os.ttyname(0).removeprefix("/dev/")
    except OSError:
        return ""


wire.register(Hello, Asked, *c.REQUESTS)
