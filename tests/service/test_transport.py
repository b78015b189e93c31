"""Messages over a Unix socket: whole, bounded in time, and only for this user."""

from __future__ import annotations

import os
import shutil
import socket
import stat
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from giraff_console.robot.odometry import Pose
from giraff_console.service.runtime_folder import runtime_folder, socket_path
from giraff_console.service.transport import (
    MAX_LINE,
    Connection,
    ConnectionClosed,
    DaemonRunning,
    LineBuffer,
    NoDaemon,
    TransportError,
    accept,
    connect,
    listen,
)
from giraff_console.service.wire import WireError, register

register(Pose)

# Long enough for a loaded machine, short enough that a hang fails fast.
WAIT_S = 2.0


@pytest.fixture
def short_dir() -> Iterator[Path]:
    # AF_UNIX paths are limited to about 107 bytes; pytest's tmp_path can be longer.
    folder = Path(tempfile.mkdtemp(dir="/tmp"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def pair() -> Iterator[tuple[Connection, Connection]]:
    left, right = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    a, b = Connection(left), Connection(right)
    yield a, b
    a.close()
    b.close()


@pytest.fixture
def raw_pair() -> Iterator[tuple[socket.socket, Connection]]:
    """A bare socket to write anything at all, and the Connection that reads it."""
    left, right = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    left.settimeout(WAIT_S)
    connection = Connection(right)
    yield left, connection
    left.close()
    connection.close()


def test_messages_go_both_ways_through_listen_and_connect(short_dir):
    path = short_dir / "robot.sock"
    server = listen(path)
    try:
        with connect(path) as client, accept(server, WAIT_S) as daemon:
            client.send(Pose(1.0, 2.0, 0.5))
            assert daemon.receive(WAIT_S) == Pose(1.0, 2.0, 0.5)
            daemon.send({"answer": [1, "two", None]})
            assert client.receive(WAIT_S) == {"answer": [1, "two", None]}
    finally:
        server.close()


def test_accept_with_no_one_connecting_gives_none(short_dir):
    server = listen(short_dir / "robot.sock")
    try:
        assert accept(server, 0.05) is None
    finally:
        server.close()


def test_the_socket_is_only_for_its_user(short_dir):
    path = short_dir / "robot.sock"
    server = listen(path)
    try:
        assert stat.S_IMODE(os.stat(path).st_mode) == 0o600
    finally:
        server.close()


def test_a_stale_socket_file_is_replaced(short_dir):
    path = short_dir / "robot.sock"
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(path))
    dead.close()  # the file stays, as after a daemon that was killed
    server = listen(path)
    try:
        with connect(path) as client, accept(server, WAIT_S) as daemon:
            client.send("hello")
            assert daemon.receive(WAIT_S) == "hello"
    finally:
        server.close()


def test_a_live_daemon_is_not_replaced(short_dir):
    path = short_dir / "robot.sock"
    server = listen(path)
    try:
        with pytest.raises(DaemonRunning, match="already running"):
            listen(path)
    finally:
        server.close()


def test_a_file_that_is_not_a_socket_is_left_alone(short_dir):
    path = short_dir / "robot.sock"
    path.write_text("mine")
    with pytest.raises(TransportError, match="not a socket"):
        listen(path)
    assert path.read_text() == "mine"


def test_connect_without_a_socket_file_is_no_daemon(short_dir):
    with pytest.raises(NoDaemon, match=f"no giraff-console daemon at {short_dir}"):
        connect(short_dir / "robot.sock", timeout=WAIT_S)


def test_connect_to_a_stale_socket_file_is_no_daemon(short_dir):
    path = short_dir / "robot.sock"
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(path))
    dead.close()
    with pytest.raises(NoDaemon, match="refused"):
        connect(path, timeout=WAIT_S)


def test_a_garbled_line_is_a_wire_error_and_the_next_line_still_arrives(raw_pair):
    writer, connection = raw_pair
    writer.sendall(b'{"not json\n"after"\n')
    with pytest.raises(WireError, match="not JSON"):
        connection.receive(WAIT_S)
    assert connection.receive(WAIT_S) == "after"


def test_a_line_that_cannot_be_decoded_is_skipped(raw_pair):
    writer, connection = raw_pair
    writer.sendall(b'{"type":"Foo"}\n{"type":"Pose","x":1.0}\n')
    with pytest.raises(WireError, match="unknown type 'Foo'"):
        connection.receive(WAIT_S)
    assert connection.receive(WAIT_S) == Pose(1.0)


def test_an_oversized_line_is_a_wire_error_and_is_skipped(raw_pair):
    writer, connection = raw_pair
    # More than the socket buffer holds: written from a thread while the reader drains.
    thread = threading.Thread(
        target=writer.sendall, args=(b"x" * (MAX_LINE + 100) + b'\n"after"\n',), daemon=True
    )
    thread.start()
    with pytest.raises(WireError, match="over 1048576 bytes"):
        connection.receive(WAIT_S)
    assert connection.receive(WAIT_S) == "after"
    thread.join(WAIT_S)
    assert not thread.is_alive()


def test_an_oversized_message_is_not_sent(pair):
    a, b = pair
    with pytest.raises(WireError, match="over the 1048576 limit"):
        a.send("x" * MAX_LINE)
    a.send("small")
    assert b.receive(WAIT_S) == "small"


def test_receive_gives_none_when_nothing_comes(pair):
    a, _ = pair
    started = time.monotonic()
    assert a.receive(0.05) is None
    assert time.monotonic() - started < 1.0


def test_the_end_of_the_stream_is_connection_closed(pair):
    a, b = pair
    b.close()
    with pytest.raises(ConnectionClosed):
        a.receive(WAIT_S)


def test_a_send_to_a_peer_that_has_gone_is_connection_closed(pair):
    a, b = pair
    b.close()
    with pytest.raises(ConnectionClosed):
        for _ in range(100):  # the first may still fit in the buffer
            a.send("hello")


def test_a_peer_that_never_reads_makes_send_fail_within_its_timeout():
    left, right = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    sender, idle = Connection(left, send_timeout=0.2), Connection(right)
    message = ["x" * 100] * 1000  # about 100 kB a line
    started = time.monotonic()
    try:
        with pytest.raises(ConnectionClosed, match="peer not reading"):
            for _ in range(200):
                sender.send(message)
        assert time.monotonic() - started < WAIT_S
    finally:
        sender.close()
        idle.close()


def test_lines_sent_from_several_threads_stay_whole(pair):
    a, b = pair

    def send_many(thread: int) -> None:
        for n in range(50):
            a.send([thread, n, "y" * 200])

    threads = [threading.Thread(target=send_many, args=(t,), daemon=True) for t in range(4)]
    for thread in threads:
        thread.start()
    received = [b.receive(WAIT_S) for _ in range(200)]
    for thread in threads:
        thread.join(WAIT_S)
    assert sorted((m[0], m[1]) for m in received) == [(t, n) for t in range(4) for n in range(50)]


def test_closing_twice_does_nothing(pair):
    a, _ = pair
    a.close()
    a.close()
    assert a.fileno() == -1
    with pytest.raises(ConnectionClosed):
        a.send("after close")
    with pytest.raises(ConnectionClosed):
        a.receive(WAIT_S)


def test_the_runtime_folder_is_in_xdg_runtime_dir_and_private(short_dir, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(short_dir))
    folder = runtime_folder()
    assert folder == short_dir / "giraff-console"
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    assert socket_path() == folder / "robot.sock"


def test_a_loose_runtime_folder_is_tightened(short_dir, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(short_dir))
    (short_dir / "giraff-console").mkdir()
    os.chmod(short_dir / "giraff-console", 0o777)
    assert stat.S_IMODE(os.stat(runtime_folder()).st_mode) == 0o700


def test_a_symlinked_runtime_folder_is_refused(short_dir, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(short_dir))
    (short_dir / "elsewhere").mkdir()
    (short_dir / "giraff-console").symlink_to(short_dir / "elsewhere")
    with pytest.raises(TransportError, match="not a folder"):
        runtime_folder()


@pytest.mark.skipif(os.getuid() != 0, reason="giving a folder away needs root")
def test_a_runtime_folder_of_another_user_is_refused(short_dir, monkeypatch):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(short_dir))
    (short_dir / "giraff-console").mkdir(mode=0o700)
    os.chown(short_dir / "giraff-console", 4242, -1)
    with pytest.raises(TransportError, match="another user"):
        runtime_folder()


def test_without_xdg_runtime_dir_the_folder_is_in_tmp(monkeypatch):
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    expected = Path(f"/tmp/giraff-console-{os.getuid()}")
    existed = expected.exists()
    try:
        assert runtime_folder() == expected
        assert stat.S_IMODE(os.stat(expected).st_mode) == 0o700
    finally:
        if not existed:
            shutil.rmtree(expected, ignore_errors=True)


def test_a_socket_path_is_in_the_folder_given(short_dir):
    assert socket_path(short_dir) == short_dir / "robot.sock"


def test_a_line_nested_too_deep_is_a_wire_error(raw_pair):
    writer, connection = raw_pair
    writer.sendall(b"[" * 10_000 + b"]" * 10_000 + b'\n"after"\n')
    with pytest.raises(WireError, match="nested too deep"):
        connection.receive(WAIT_S)
    assert connection.receive(WAIT_S) == "after"


def test_a_line_buffer_drops_an_oversized_line_as_it_streams_and_holds_no_more_than_its_limit():
    lines = LineBuffer(100)
    lines.add(b'"ok"\n' + b"x" * 150)
    assert lines.take() == b'"ok"'
    with pytest.raises(WireError, match="over 100 bytes"):
        lines.take()
    for _ in range(50):  # the rest of the long line, never kept
        lines.add(b"x" * 1000)
        assert len(lines) == 0 and lines.take() is None
    lines.add(b'x\n"after"\n')
    assert lines.take() == b'"after"'
