"""The link against ports that misbehave, over real pseudo-terminals.

Every wait has a deadline: a silent port, a port full of garbage and a board that
stops answering all raise typed errors in time, and a late reply is never taken for
the answer to a later command.
"""

from __future__ import annotations

import os
import random
import threading
import time

import pytest
import serial

from giraff_console.link import BoardLink, LinkDisconnected, LinkTimeout
from giraff_console.protocol import BoardRebootedError, ProtocolError, encode_float
from tests.link.scripted import ScriptedBoard, well_behaved

TIMEOUT = 0.3


def test_a_port_that_does_not_exist():
    with pytest.raises(LinkDisconnected, match="cannot open"):
        BoardLink.open("/dev/does-not-exist-giraff")


def test_a_silent_port_raises_within_the_timeouts(pty_pair):
    _, path = pty_pair
    start = time.monotonic()
    with pytest.raises(LinkTimeout, match="no answer"):
        BoardLink.open(path, timeout=TIMEOUT, handshake_timeout=TIMEOUT)
    assert time.monotonic() - start < 2 * TIMEOUT + 0.2


@pytest.mark.parametrize("with_newlines", [False, True])
def test_a_port_full_of_garbage_raises_within_the_timeouts(pty_pair, with_newlines):
    master, path = pty_pair
    stop = threading.Event()
    noise = random.Random(1)

    def spew() -> None:
        while not stop.is_set():
            data = bytes(noise.randrange(256) for _ in range(64))
            if with_newlines:
                data += b"\r\n"
            try:
                os.write(master, data)
            except BlockingIOError:
                pass  # the pty is full: never block, so that the thread sees `stop`
            except OSError:
                return
            time.sleep(0.002)

    os.set_blocking(master, False)
    thread = threading.Thread(target=spew, daemon=True)
    thread.start()
    try:
        start = time.monotonic()
        with pytest.raises(LinkTimeout):
            BoardLink.open(path, timeout=TIMEOUT, handshake_timeout=TIMEOUT)
        assert time.monotonic() - start < 2 * TIMEOUT + 0.2
    finally:
        stop.set()
        thread.join(timeout=5)
        assert not thread.is_alive()


@pytest.fixture
def scripted(pty_pair):
    master, path = pty_pair
    boards: list[ScriptedBoard] = []

    def start(answer=well_behaved) -> tuple[ScriptedBoard, BoardLink]:
        board = ScriptedBoard(master, answer)
        board.start()
        boards.append(board)
        return board, BoardLink.open(path, timeout=TIMEOUT, handshake_timeout=0.1)

    yield start
    for board in boards:
        board.stop()


def test_a_late_reply_is_never_paired_with_the_next_command(scripted):
    late = {"done": False}

    def answer(command: str) -> bytes | None:
        if command == "get v" and not late["done"]:
            late["done"] = True
            time.sleep(TIMEOUT + 0.1)  # answers, but only after the link gave up
        return well_behaved(command)

    _board, link = scripted(answer)
    resyncs = []
    link.add_observer(
        lambda exchange: resyncs.append(exchange) if exchange.kind == "resync" else None
    )
    with pytest.raises(LinkTimeout):
        link.get("v")
    assert link.get("a") == pytest.approx(0.5)  # not v's 0.3
    assert any(encode_float(0.3) in exchange.lines for exchange in resyncs)


def test_a_board_that_stops_answering_times_out_every_time(scripted):
    silent = threading.Event()
    _board, link = scripted(lambda command: None if silent.is_set() else well_behaved(command))
    assert link.get("v") == pytest.approx(0.3)
    silent.set()
    for _ in range(2):
        start = time.monotonic()
        with pytest.raises(LinkTimeout):
            link.get("a")
        assert time.monotonic() - start < TIMEOUT + 0.15


def test_a_garbled_value_is_a_protocol_error_and_the_line_stays_in_step(scripted):
    board, link = scripted(
        lambda command: b"F*zz\r\nOK >\r\n" if command == "get v" else well_behaved(command)
    )
    with pytest.raises(ProtocolError):
        link.get("v")
    before = len(board.commands)
    assert link.get("a") == pytest.approx(0.5)
    assert board.commands[before:] == ["get a"]  # no resync was needed


def test_a_board_that_reboots_mid_session_is_reported(scripted):
    _board, link = scripted(
        lambda command: (
            b"# Giraf 1.1.112p, 2011-02-20\r\nOK >\r\n"
            if command == "get v"
            else well_behaved(command)
        )
    )
    with pytest.raises(BoardRebootedError):
        link.get("v")
    assert link.get("a") == pytest.approx(0.5)


def test_noise_before_the_banner_is_skipped(pty_pair):
    master, path = pty_pair
    board = ScriptedBoard(master)
    board.start()
    try:
        link = BoardLink(serial.Serial(path, 115200), timeout=TIMEOUT)
        os.write(master, b"\x00\xffCa>\r\nxx#\r\n# Giraf 1.1.112p, 2011-02-20\r\nOK >\r\n")
        assert link.handshake(power_line="none", timeout=TIMEOUT) == "1.1.112p, 2011-02-20"
        assert link.get("v") == pytest.approx(0.3)
    finally:
        board.stop()


def test_a_stale_probe_answer_is_not_taken_for_the_current_one(scripted):
    board, link = scripted()
    link.get("v")
    os.write(board.master, b"Unknown name: sync_1\r\nOK >\r\n")  # left over from long ago
    time.sleep(0.05)
    assert link.get("a") == pytest.approx(0.5)


def test_an_unknown_name_for_another_command_means_out_of_step(scripted):
    board, link = scripted(
        lambda command: (
            b"Unknown name: zz\r\nOK >\r\n" if command == "get v" else well_behaved(command)
        )
    )
    with pytest.raises(ProtocolError, match="out of step"):
        link.get("v")
    before = len(board.commands)
    assert link.get("a") == pytest.approx(0.5)
    assert board.commands[before].startswith("get sync_")  # resynchronised first


def test_a_get_answered_with_only_a_prompt_is_a_protocol_error(scripted):
    _, link = scripted(lambda command: b"OK >\r\n" if command == "get v" else well_behaved(command))
    with pytest.raises(ProtocolError, match="no value"):
        link.get("v")
