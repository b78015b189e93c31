"""One command and its answer, as the link reports it to its observers."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.replies import ReplyValue

ExchangeKind = Literal["greeting", "set", "get", "command", "resync"]


@dataclass(frozen=True)
class Exchange:
    """A command sent and what came back, with monotonic timestamps.

    `lines` are the reply lines before the prompt; `value` their decoded value. For a
    resync, `lines` are what was discarded. `error` is set when the exchange failed.
    `automatic` marks traffic the console generates by itself, such as the odometry
    poll, which the original kept out of its transcript and flagged in its log (B.2).
    """

    kind: ExchangeKind
    command: str
    lines: tuple[str, ...]
    value: ReplyValue
    error: GiraffError | None
    sent_at: float
    answered_at: float
    automatic: bool = False


Observer = Callable[[Exchange], None]
