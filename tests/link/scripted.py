"""A misbehaving board played on the master side of a real pseudo-terminal."""

from __future__ import annotations

import os
import select
import threading
from collections.abc import Callable

from giraff_console.protocol import encode_float

Answer = Callable[[str], bytes | None]


def well_behaved(command: str) -> bytes | None:
    """What a board says to the commands these tests use."""
    words = command.split()
    if words[:1] == ["get"] and words[1].startswith("sync_"):
        return f"Unknown name: {words[1]}\r\nOK >\r\n".encode()
    values = {"get v": 0.3, "get a": 0.5}
    if command in values:
        return f"{encode_float(values[command])}\r\nOK >\r\n".encode()
    return b"OK >\r\n"


class ScriptedBoard(threading.Thread):
    """Answers each command line with `answer(line)`; None means silence."""

    def __init__(self, master: int, answer: Answer = well_behaved) -> None:
        super().__init__(daemon=True)
        self.master = master
        self.answer = answer
        self.commands: list[str] = []
        self._stop_event = threading.Event()
        self._partial = b""

    def run(self) -> None:
        while not self._stop_event.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.02)
            if not ready:
                continue
            try:
                self._partial += os.read(self.master, 1024)
            except OSError:
                return
            while b"\r" in self._partial:
                raw, self._partial = self._partial.split(b"\r", 1)
                command = raw.decode("ascii", "replace")
                self.commands.append(command)
                reply = self.answer(command)
                if reply:
                    os.write(self.master, reply)

    def stop(self) -> None:
        self._stop_event.set()
        self.join(timeout=2)
