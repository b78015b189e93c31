"""Many consoles and many connection attempts on the daemon's socket, from one process
(issue 30): the flood of bench/daemon_flood.py, which starts it.

Each attached console is a real client as far as the daemon can tell: it says `Hello`
(not asking for the controls: the flood watches, it does not drive), reads everything
the daemon sends it and beats its heart every 0.5 s, as service/remote.py's does. Each
connection attempt connects, then, in turn, says nothing, sends a line of junk, or says
`Hello`, and hangs up after a while, as the owner's own programs gone wrong would.

One asyncio loop holds them all, so that the flood costs the machine sockets rather
than threads. A connect the daemon's backlog cannot take yet (EAGAIN on a Unix socket)
is tried again every 10 ms until its deadline, as a client with a connect timeout
would wait (service/transport.py's `connect` waits 2 s).

Driven by lines on standard input, answered with one JSON line on standard output each:

    attach N K        attach N consoles, K at a time
                                            -> {"attached": a, "refused": r, "seconds": s}
    attempts N HOLD   N attempts at once, each held HOLD s
                                            -> {"attempts": {outcome: count}, "seconds": s}
    end               hang up on everything -> {"dropped": d}: consoles the daemon hung up on

Usage (by bench/daemon_flood.py): python bench/console_flood.py SOCKET
"""

from __future__ import annotations

import asyncio
import collections
import enum
import json
import resource
import socket
import sys
import time
from pathlib import Path

HELLO = b'{"type":"Hello","console":"flood","take":false}\n'
HEARTBEAT = b'{"type":"Asked","number":0,"request":{"type":"Heartbeat"}}\n'
WELCOME = b'"type":"Welcome"'  # how the daemon's first line begins (transport.py)
JUNK = b"\x00{not json at all]\n"
HEARTBEAT_S = 0.5  # service/remote.py's
CONSOLE_CONNECT_S = 5.0  # a console waits as long for its welcome (remote.py)
ATTEMPT_CONNECT_S = 2.0  # transport.connect's timeout
WELCOME_S = 5.0
RETRY_S = 0.01
READ_CHUNK = 65536


class Attempt(enum.Enum):
    """What became of one connection attempt."""

    REFUSED = "refused"  # connect failed, or did not go through by its deadline
    HUNG_UP_ON = "hung up on"  # the daemon closed it before the attempt let go
    HELD = "held"  # connected and let go of by the attempt, the daemon still holding it
    WELCOMED = "welcomed"  # a Hello attempt that the daemon welcomed


async def open_connection(path: Path, deadline: float) -> socket.socket | None:
    """A connected non-blocking socket to `path`, or None if the daemon refused it or
    its backlog did not take it before `deadline` (time.monotonic())."""
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.setblocking(False)
    while True:
        try:
            sock.connect(str(path))
            return sock
        except BlockingIOError:  # the listen backlog is full: try again shortly
            if time.monotonic() > deadline:
                sock.close()
                return None
            await asyncio.sleep(RETRY_S)
        except OSError:  # refused, no such file, out of descriptors
            sock.close()
            return None


class Console:
    """One attached console: Hello, then read everything and beat its heart."""

    def __init__(self) -> None:
        self.welcomed = asyncio.Event()
        self.hung_up_on = False
        self._task: asyncio.Task[None] | None = None

    async def attach(self, path: Path, at_once: asyncio.Semaphore) -> bool:
        """Whether the daemon welcomed it; `at_once` bounds the consoles attaching at the
        same time, as consoles started over a few seconds would come."""
        async with at_once:
            sock = await open_connection(path, time.monotonic() + CONSOLE_CONNECT_S)
            if sock is None:
                return False
            reader, writer = await asyncio.open_unix_connection(sock=sock, limit=2**21)
            self._task = asyncio.create_task(self._run(reader, writer))
            try:
                await asyncio.wait_for(self.welcomed.wait(), WELCOME_S)
            except TimeoutError:
                return False
            return True

    async def _run(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        beating = asyncio.create_task(self._beat(writer))
        try:
            writer.write(HELLO)
            first = await reader.readline()
            if WELCOME in first[:40]:
                self.welcomed.set()
            while await reader.read(READ_CHUNK):
                pass
            self.hung_up_on = True  # the end of the stream came from the daemon
        except (ConnectionError, asyncio.LimitOverrunError, ValueError):
            self.hung_up_on = True
        finally:
            beating.cancel()
            writer.close()

    @staticmethod
    async def _beat(writer: asyncio.StreamWriter) -> None:
        while True:
            await asyncio.sleep(HEARTBEAT_S)
            writer.write(HEARTBEAT)
            if writer.transport.get_write_buffer_size() > 2**20:
                return  # the daemon reads nothing: no point queueing more

    def close(self) -> None:
        if self._task is not None:
            self._task.cancel()


async def attempt(path: Path, kind: int, hold: float) -> Attempt:
    """Connect; say nothing (0), send junk (1) or Hello (2); hang up after `hold` s."""
    sock = await open_connection(path, time.monotonic() + ATTEMPT_CONNECT_S)
    if sock is None:
        return Attempt.REFUSED
    reader, writer = await asyncio.open_unix_connection(sock=sock, limit=2**21)
    outcome = Attempt.HELD
    try:
        writer.write((b"", JUNK, HELLO)[kind])
        end = time.monotonic() + hold
        while (left := end - time.monotonic()) > 0:
            try:
                data = await asyncio.wait_for(reader.read(READ_CHUNK), left)
            except TimeoutError:
                break
            if not data:
                return Attempt.HUNG_UP_ON
            if kind == 2 and WELCOME in data[:40]:
                outcome = Attempt.WELCOMED
    except ConnectionError:
        return Attempt.HUNG_UP_ON
    finally:
        writer.close()
    return outcome


async def serve(path: Path) -> None:
    consoles: list[Console] = []
    lines = asyncio.StreamReader()
    await asyncio.get_running_loop().connect_read_pipe(
        lambda: asyncio.StreamReaderProtocol(lines), sys.stdin
    )
    while line := (await lines.readline()).decode().split():
        began = time.monotonic()
        if line[0] == "attach":
            new = [Console() for _ in range(int(line[1]))]
            at_once = asyncio.Semaphore(int(line[2]))
            attached = await asyncio.gather(*(console.attach(path, at_once) for console in new))
            consoles += new
            said: dict[str, object] = {"attached": sum(attached),
                                       "refused": len(new) - sum(attached)}  # fmt: skip
        elif line[0] == "attempts":
            hold = float(line[2])
            outcomes = await asyncio.gather(*(attempt(path, n % 3, hold)
                                              for n in range(int(line[1]))))  # fmt: skip
            said = {"attempts": dict(collections.Counter(o.value for o in outcomes))}
        else:  # end
            said = {"dropped": sum(console.hung_up_on for console in consoles)}
            for console in consoles:
                console.close()
            print(json.dumps(said), flush=True)
            return
        said["seconds"] = round(time.monotonic() - began, 3)
        print(json.dumps(said), flush=True)


def main() -> int:
    # Each console and attempt is a descriptor here as well as in the daemon.
    _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    asyncio.run(serve(Path(sys.argv[1])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
