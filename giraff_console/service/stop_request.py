"""`giraff-console stop` in a hurry: the operator's stop from a shell (issue 30, item 3).

A stop must take effect within 0.2 s of being typed, however busy the robot's PC. The
consoles' client (remote.py) loads most of the package to read everything the daemon
says (telemetry, maps, the missions' reports), and even the requests' own types
(commands.py) bring in the robot's: 0.2 s of imports on an idle robot PC, more on a
loaded one, before the stop could even be sent. A stop needs none of that: it says
Hello, asks Halt (or Shutdown), and waits for that one answer, passing over every other
line without building it. Its two lines are written here as plain JSON, the very lines
wire.py's encoding gives console_hello.Hello and Asked (tests/service/test_stop_request.py
holds them to it), so the daemon serves it as any console, over the connection limit too
(daemon.py).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from giraff_console.service.console_name import console_name
from giraff_console.service.transport import ConnectionClosed, TransportError, connect
from giraff_console.service.wire_error import WireError

# The number the stop is asked by; the daemon answers refusals it cannot number with -1
# (too many consoles, no descriptors left, a line it could not read).
NUMBER = 1
UNNUMBERED = -1
# The tags of the messages on the wire (wire.py's "type": the classes' names).
HELLO, ASKED, HALT, SHUTDOWN, ANSWERED = "Hello", "Asked", "Halt", "Shutdown", "Answered"


class StopAnswer:
    """What the daemon said to the stop: done or refused, and its words. (Not a
    dataclass: dataclasses loads inspect, 0.01-0.02 s of a stop's start.)"""

    __slots__ = ("ok", "text")

    def __init__(self, ok: bool, text: str) -> None:
        self.ok = ok
        self.text = text


def ask_stop(path: Path, *, shutdown: bool = False, timeout: float = 5.0) -> StopAnswer:
    """Stop the robot (and end the daemon too, if `shutdown`) through the daemon at
    `path`; NoDaemon if none listens there, TransportError if it cannot be reached or
    does not answer within `timeout` seconds."""
    deadline = time.monotonic() + timeout
    answer, numbered = _ask(path, shutdown, deadline)
    if not answer.ok and not numbered and time.monotonic() < deadline:
        # Refused before it was read (a connection the daemon had no room for, in a
        # flood of them): asked once more.
        answer, _ = _ask(path, shutdown, deadline)
    return answer


def stop_lines(shutdown: bool = False) -> bytes:
    """What the stop sends, in one write: a Hello that does not take the controls, and
    the Halt (or Shutdown) numbered NUMBER; a line each."""
    hello = {"type": HELLO, "console": console_name("stop"), "take": False}
    asked = {"type": ASKED, "number": NUMBER, "request": {"type": SHUTDOWN if shutdown else HALT}}
    return b"".join(json.dumps(line, separators=(",", ":")).encode() + b"\n"
                    for line in (hello, asked))  # fmt: skip


def _ask(path: Path, shutdown: bool, deadline: float) -> tuple[StopAnswer, bool]:
    """The daemon's answer, and whether it was to the stop (not a refusal of the
    connection before it was read)."""
    with connect(path, max(deadline - time.monotonic(), 0.1)) as connection:
        try:
            # In one write: the daemon reads the stop with the Hello, in the same turn.
            connection.send_lines(stop_lines(shutdown))
            while (remaining := deadline - time.monotonic()) > 0:
                try:
                    line = connection.receive_line(remaining)
                except WireError:  # a line too long for any answer: not the stop's
                    continue
                found = None if line is None else _answer_in(line)
                if found is not None:
                    return found
        except ConnectionClosed as error:
            why = f"the daemon at {path} hung up before it answered: {error}"
            raise TransportError(why) from None
    raise TransportError(f"the daemon at {path} did not answer the stop in time")


def _answer_in(line: bytes) -> tuple[StopAnswer, bool] | None:
    """The answer to the stop, and whether it was numbered as the stop, if `line`
    carries it; None for every other message."""
    try:
        message = json.loads(line)
    except ValueError:
        return None
    if not isinstance(message, dict) or message.get("type") != ANSWERED:
        return None
    reply, number = message.get("reply"), message.get("number")
    if number not in (NUMBER, UNNUMBERED) or not isinstance(reply, dict):
        return None
    ok, text = reply.get("ok"), reply.get("text", "")
    if not isinstance(ok, bool) or not isinstance(text, str):
        return None
    return StopAnswer(ok, text), number == NUMBER
