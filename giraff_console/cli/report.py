"""How every command says that something went wrong: one line on standard error, and
the exit code."""

from __future__ import annotations

import sys


def fail(message: str, code: int) -> int:
    """Say what went wrong; the exit code."""
    print(f"giraff-console: {message}", file=sys.stderr)
    return code
