"""The simulator as a pyserial port: serial.serial_for_url("giraff-sim://...")."""

from __future__ import annotations

import pytest
import serial

import giraff_console  # noqa: F401  (registers giraff-sim://)
from giraff_console.sim import GiraffBoard


def open_port(query: str = "") -> serial.SerialBase:
    return serial.serial_for_url(f"giraff-sim://?clock=virtual{query}", timeout=0.5)


def read_reply(port: serial.SerialBase) -> bytes:
    data = b""
    while not data.endswith(b"OK >\r\n"):
        chunk = port.read(max(1, port.in_waiting))
        assert chunk, f"no prompt after {data!r}"
        data += chunk
    return data


def test_the_board_greets_when_the_port_opens():
    port = open_port()
    assert isinstance(port.board, GiraffBoard)
    assert read_reply(port).startswith(b"# Giraf ")


def test_commands_are_answered():
    port = open_port()
    read_reply(port)
    port.write(b"get v\r")
    assert read_reply(port) == b"F*9a99193f\r\nOK >\r\n"


def test_dropping_dtr_powers_the_board_down_and_raising_it_reboots():
    port = open_port()
    read_reply(port)
    for command in (b"set r 1\r", b"set p 5\r"):
        port.write(command)
        read_reply(port)
    port.clock.advance(2.0)
    port.dtr = False
    x = port.board.true_pose.x
    port.clock.advance(1.0)
    assert port.board.true_pose.x == x  # stopped dead
    port.write(b"get v\r")
    assert port.read(10) == b""  # an unpowered board says nothing
    port.dtr = True
    assert read_reply(port).startswith(b"# Giraf")


def test_ftdi_cables_power_the_board_with_rts():
    port = open_port("&power=rts")
    read_reply(port)
    port.dtr = False  # the wrong line: nothing happens
    port.write(b"get a\r")
    assert read_reply(port) == b"F*9a99193f\r\nOK >\r\n"
    port.rts = False
    port.rts = True
    assert read_reply(port).startswith(b"# Giraf")


def test_noise_and_ca_before_the_banner_on_request():
    greeting = read_reply(open_port("&noise=1&ca=1"))
    assert greeting.index(b"Ca>") < greeting.index(b"# Giraf")
    assert not greeting.startswith(b"Ca>")  # noise came first


def test_a_read_times_out_on_the_ports_clock():
    port = open_port()
    read_reply(port)
    start = port.clock.now()
    assert port.read(1) == b""
    assert port.clock.now() - start == pytest.approx(0.5)


@pytest.mark.parametrize("query", ["&bogus=1", "&pace=2", "&clock=sundial", "&hex=mixed"])
def test_bad_options_are_refused_clearly(query):
    with pytest.raises(serial.SerialException, match="giraff-sim"):
        open_port(query)


def test_options_reach_the_board():
    port = open_port("&imperfect=1&seed=4&hex=upper&set_reply=none&trailing_comma=0&auto_home=1")
    config = port.board.config
    assert config.imperfections.seed == 4 and config.imperfections.move_error_m > 0
    assert (config.hex_upper, config.set_reply, config.list_trailing_comma, config.auto_home) == (
        True, "none", False, True,
    )  # fmt: skip
