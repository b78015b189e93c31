"""How other consoles see a console: what it is and where it runs. Apart from
console_hello.py, so that `giraff-console stop` names itself without loading the
requests' types (stop_request.py)."""

from __future__ import annotations

import os


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
