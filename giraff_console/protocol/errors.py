"""Typed errors for everything that can go wrong on the wire.

Every expected failure in giraff-console derives from `GiraffError`, so a front end can
catch that one class and show its message to the operator without a traceback.
"""

from __future__ import annotations


class GiraffError(Exception):
    """An expected failure; its message is written for the operator."""


class CommandError(GiraffError, ValueError):
    """A command that must not be sent: bad name, bad value, or an embedded line break."""


class ProtocolError(GiraffError):
    """Bytes from the board that do not follow the wire format (Appendix A.3)."""


class BoardRebootedError(ProtocolError):
    """The board printed its version banner in the middle of a session.

    It has lost every setting and any move in progress; the console must treat the
    robot as freshly powered up.
    """


class BoardError(GiraffError):
    """The board answered a command with an error line instead of a value."""

    def __init__(self, line: str) -> None:
        super().__init__(f"board error: {line}")
        self.line = line


class UnknownNameError(BoardError):
    """`Unknown name: X`: the board has no parameter or command called X."""

    def __init__(self, line: str, name: str) -> None:
        super().__init__(line)
        self.name = name


class QueueRolloverError(BoardError):
    """`ERROR: Queue rollover`: the buffered-move queue (4 slots, A.4.8) is full."""


class ArgumentError(BoardError):
    """`Error: ...`: the board rejected a command's argument."""
