"""What a console says first and how it asks: the two messages every client sends.

Apart from the daemon (daemon.py), which brings in most of the robot's types to tell the
consoles everything, so that a client that only asks need not load them. `giraff-console
stop` writes the same two lines without even these (stop_request.py, issue 30).
"""

from __future__ import annotations

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


wire.register(Hello, Asked, *c.REQUESTS)
