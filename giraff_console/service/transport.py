"""Messages over a Unix stream socket: one JSON value a line, each through wire.py.

The daemon (`giraff-console serve`) listens on a socket in a folder only its user can
open (runtime_folder.py), and the front ends connect to it. Only a Unix socket, never
TCP: whoever can reach it can drive the robot, and the file's owner and mode say who
that is.

Every wait is bounded. A peer that stops reading must not block the sender, which may
be the thread that hands telemetry to every front end; a peer that vanishes must not
block the reader.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import select
import socket
import stat
import sys
import threading
import time
from pathlib import Path

from giraff_console.service.wire_error import WireError

# One message a line. A telemetry snapshot is about 2 kB; a line past this is a peer
# that is not speaking the protocol, and is thrown away rather than buffered for ever.
MAX_LINE = 1024 * 1024
SEND_TIMEOUT_S = 2.0
# Seconds between tries to connect to a daemon whose backlog is full.
CONNECT_RETRY_S = 0.005
# Connections the kernel holds for the daemon to take (capped by net.core.somaxconn).
# Deep: a Unix socket whose backlog is full refuses a connection at once, so behind a
# flood of connections `giraff-console stop` would have to win a race of retries;
# queued, it waits its turn while the daemon takes them by the hundred (daemon.py).
BACKLOG = 1024
_CHUNK = 65536
# AF_UNIX paths are limited to 108 bytes with the terminating NUL (sun_path, unix(7)).
_MAX_PATH = 107


class TransportError(Exception):
    """The connection to the daemon, or the place it listens at, cannot be used."""


class ConnectionClosed(TransportError):
    """The peer has gone, or stopped reading, or the connection was closed here."""


class NoDaemon(TransportError):
    """Nothing is listening at the socket's path."""

    def __init__(self, path: Path, reason: str) -> None:
        super().__init__(f"no giraff-console daemon at {path}: {reason}")
        self.path = path


class DaemonRunning(TransportError):
    """A daemon already answers at the socket's path."""

    def __init__(self, path: Path) -> None:
        super().__init__(f"a giraff-console daemon is already running at {path}")
        self.path = path


class Connection:
    """A connected socket that sends and receives whole messages.

    Several threads may send at once (a lock keeps their lines whole); one thread at a
    time receives."""

    def __init__(self, sock: socket.socket, send_timeout: float = SEND_TIMEOUT_S) -> None:
        # The socket timeout bounds `sendall` as a whole (Python 3.5+); receiving waits
        # on poll first, so it never depends on it.
        sock.settimeout(send_timeout)
        self._socket = sock
        self._send_lock = threading.Lock()
        self._receive_lock = threading.Lock()
        self._lines = LineBuffer(MAX_LINE)
        self._closed = False

    def fileno(self) -> int:
        return self._socket.fileno()

    def peer_pid(self) -> int | None:
        """The process at the other end, as the kernel says (SO_PEERCRED), or None."""
        return peer_pid(self._socket)

    def send(self, *messages: object) -> None:
        """Send these messages, in one write; ConnectionClosed if the peer has gone or
        is not reading."""
        self.send_lines(b"".join(encode_line(message) for message in messages))

    def send_lines(self, line: bytes) -> None:
        """Send lines already encoded, whole, in one write; ConnectionClosed as `send`."""
        with self._send_lock:
            if self._closed:
                raise ConnectionClosed("connection closed")
            try:
                self._socket.sendall(line)
            except TimeoutError:
                # Part of the line may have gone: the stream cannot be resumed.
                self.close()
                raise ConnectionClosed("peer not reading") from None
            except OSError as error:  # BrokenPipe, ConnectionReset, or closed under us
                self.close()
                raise ConnectionClosed(f"peer gone ({error.strerror or error})") from None

    def receive(self, timeout: float) -> object | None:
        """The next message, or None if none came within `timeout` seconds.

        ConnectionClosed at the end of the stream. WireError for a line that is too
        long, not JSON, or not something wire.decode can build; that line is skipped,
        so the next receive goes on with the line after it."""
        line = self.receive_line(timeout)
        return None if line is None else parse(line)

    def receive_line(self, timeout: float) -> bytes | None:
        """The next line as it came, unread, or None if none came within `timeout`
        seconds; ConnectionClosed and WireError as for `receive`."""
        deadline = time.monotonic() + max(timeout, 0.0)
        with self._receive_lock:
            while True:
                line = self._lines.take()
                if line is not None:
                    return line
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not self._wait_readable(remaining):
                    return None
                self._read_chunk()

    def _wait_readable(self, timeout: float) -> bool:
        descriptor = self._socket.fileno()  # -1 once closed, perhaps by another thread
        if self._closed or descriptor < 0:
            raise ConnectionClosed("connection closed")
        poller = select.poll()
        poller.register(descriptor, select.POLLIN)
        return bool(poller.poll(timeout * 1000))

    def _read_chunk(self) -> None:
        try:
            # Readable, so this returns at once; the send timeout is only a backstop.
            chunk = self._socket.recv(_CHUNK)
        except TimeoutError:
            return
        except OSError as error:
            self.close()
            raise ConnectionClosed(f"peer gone ({error.strerror or error})") from None
        if not chunk:
            self.close()
            raise ConnectionClosed("peer closed the connection")
        self._lines.add(chunk)

    def close(self) -> None:
        """Close the connection; closing it again does nothing."""
        if self._closed:
            return
        self._closed = True
        # shutdown first: it wakes a thread waiting in receive, which close alone may not.
        with contextlib.suppress(OSError):  # the peer went first
            self._socket.shutdown(socket.SHUT_RDWR)
        self._socket.close()

    def __enter__(self) -> Connection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def peer_pid(sock: socket.socket) -> int | None:
    """The process at the other end of `sock`, as the kernel says (SO_PEERCRED), or None."""
    try:
        credentials = sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, 12)
    except OSError:
        return None
    return int.from_bytes(credentials[:4], sys.byteorder)


def encode_line(message: object) -> bytes:
    """`message` as the line that carries it; WireError if it is over MAX_LINE."""
    from giraff_console.service import wire  # not at the top: wire_error.py says why

    # allow_nan, the default: inf and nan cross as Infinity and NaN (wire.py).
    line = json.dumps(wire.encode(message), separators=(",", ":")).encode() + b"\n"
    if len(line) > MAX_LINE:
        raise WireError(f"a message of {len(line)} bytes is over the {MAX_LINE} limit")
    return line


class LineBuffer:
    """Bytes as they come off a socket, handed back a whole line at a time, never more
    than `limit` of them held: a line past it is thrown away as it streams in, unread,
    and reported once (WireError), so that a peer that never sends a newline costs
    neither memory nor the time to parse it."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._buffer = bytearray()
        self._discarding = False  # inside an oversized line, until its newline

    def add(self, chunk: bytes) -> None:
        if self._discarding:
            newline = chunk.find(b"\n")
            if newline < 0:
                return
            chunk = chunk[newline + 1 :]
            self._discarding = False
        self._buffer += chunk

    def take(self) -> bytes | None:
        """A whole line (without its newline), or None until one has come; WireError
        once for a line over the limit, which is skipped to its end."""
        newline = self._buffer.find(b"\n", 0, self.limit + 1)
        if newline < 0 and len(self._buffer) > self.limit:
            end = self._buffer.find(b"\n", self.limit)
            if end < 0:
                self._discarding = True  # the rest of it is dropped as it arrives
                self._buffer.clear()
            else:
                del self._buffer[: end + 1]
            raise WireError(f"a line over {self.limit} bytes: skipped")
        if newline < 0:
            return None
        line = bytes(self._buffer[:newline])
        del self._buffer[: newline + 1]
        return line

    def __len__(self) -> int:
        return len(self._buffer)


def parse(line: bytes) -> object:
    """The message a line holds (wire.decode); WireError if it holds none."""
    # The refusals say where, never what Python said nor the bytes themselves: a client
    # is told what was wrong with its line in the protocol's terms (issue 30, item 4).
    try:
        data = json.loads(line)
    except json.JSONDecodeError as error:
        raise WireError(f"a line that is not JSON (at byte {error.pos})") from None
    except UnicodeDecodeError as error:
        raise WireError(f"a line that is not UTF-8 (at byte {error.start})") from None
    except ValueError:  # an integer of more digits than Python converts
        raise WireError("a line with a number too long to read") from None
    except RecursionError:
        raise WireError("a line nested too deep") from None
    from giraff_console.service import wire  # not at the top: wire_error.py says why

    try:
        return wire.decode(data)
    except RecursionError:  # decoding takes more frames a level than parsing
        raise WireError("a line nested too deep") from None


def listen(path: Path) -> socket.socket:
    """A listening socket at `path` that only this user may connect to.

    DaemonRunning if a daemon already answers there; a socket file left by one that
    died is replaced. Anything else at the path is left alone: TransportError."""
    _check_length(path)
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        pass
    else:
        if not stat.S_ISSOCK(mode):
            raise TransportError(f"{path} exists and is not a socket: not replacing it")
        if _answers(path):
            raise DaemonRunning(path)
        path.unlink(missing_ok=True)  # stale: its daemon died without removing it
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    # The file is created by bind with the umask's mode: made private from the start, so
    # that no other user can connect before the chmod. The umask is the process's, so
    # it is restored at once.
    previous = os.umask(0o177)
    try:
        server.bind(str(path))
    except OSError as error:
        server.close()
        if error.errno == errno.EADDRINUSE:
            raise DaemonRunning(path) from None  # another daemon won the race
        raise TransportError(f"cannot listen at {path}: {error.strerror or error}") from None
    finally:
        os.umask(previous)
    os.chmod(path, 0o600)
    server.listen(BACKLOG)
    return server


def _answers(path: Path) -> bool:
    """Whether something accepts connections at the socket file `path`."""
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    probe.settimeout(1.0)  # a listener accepts at once; a stale file refuses at once
    try:
        probe.connect(str(path))
    except (ConnectionRefusedError, FileNotFoundError):
        return False
    except OSError:
        return True  # busy (a full backlog times out): something is there
    finally:
        probe.close()
    return True


def accept(
    server: socket.socket, timeout: float, send_timeout: float = SEND_TIMEOUT_S
) -> Connection | None:
    """The next front end to connect to `server`, or None within `timeout` seconds."""
    poller = select.poll()
    poller.register(server.fileno(), select.POLLIN)
    if not poller.poll(max(timeout, 0.0) * 1000):
        return None
    # Readable, so accept returns at once; non-blocking for just this call, in case the
    # front end left in between, and put back as it was for whoever else uses `server`.
    previous = server.gettimeout()
    server.settimeout(0)
    try:
        client, _ = server.accept()
    except (BlockingIOError, ConnectionAbortedError):
        return None
    finally:
        server.settimeout(previous)
    return Connection(client, send_timeout)


def connect(path: Path, timeout: float = 2.0) -> Connection:
    """A connection to the daemon at `path`; NoDaemon if none is listening there."""
    _check_length(path)
    if not path.exists():
        raise NoDaemon(path, "no socket file")
    deadline = time.monotonic() + timeout
    while True:
        client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        client.settimeout(timeout)
        try:
            client.connect(str(path))
        except (ConnectionRefusedError, FileNotFoundError):
            client.close()
            raise NoDaemon(path, "connection refused (a daemon that died?)") from None
        except (BlockingIOError, TimeoutError):
            # A Unix socket whose backlog is full says so at once (EAGAIN) rather than
            # wait: the daemon takes connections by the dozen, so asked again, until
            # `timeout` (a `stop` in a flood of connections must still get through).
            client.close()
            if time.monotonic() >= deadline:
                why = f"the daemon at {path} did not answer in {timeout} s"
                raise TransportError(why) from None
            time.sleep(CONNECT_RETRY_S)
            continue
        except OSError as error:
            client.close()
            raise TransportError(f"cannot connect to {path}: {error.strerror or error}") from None
        return Connection(client)


def _check_length(path: Path) -> None:
    if len(os.fsencode(path)) > _MAX_PATH:
        raise TransportError(f"socket path too long for a Unix socket ({_MAX_PATH} bytes): {path}")
