"""Errors of the serial link itself, beside the board's own (protocol.errors)."""

from __future__ import annotations

from giraff_console.protocol.errors import GiraffError


class LinkError(GiraffError):
    """The link to the board failed."""


class LinkTimeout(LinkError):
    """The board did not answer in time."""


class LinkDisconnected(LinkError):
    """The port went away or could not be opened."""
