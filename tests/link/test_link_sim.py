"""The link's typed API against the in-process simulator on a virtual clock."""

from __future__ import annotations

import pytest
import serial

from giraff_console.link import BoardLink, Exchange, MotorState
from giraff_console.protocol import BoardRebootedError, QueueRolloverError, UnknownNameError
from giraff_console.protocol.framing import BYTE_TIME_S


def open_link(query: str = "") -> BoardLink:
    return BoardLink.open(f"giraff-sim://?clock=virtual{query}")


def test_handshake_reads_the_version():
    assert open_link().version == "1.1.112p-sim, 2013-06-01"


def test_handshake_skips_noise_and_ca():
    assert open_link("&noise=1&ca=1").version == "1.1.112p-sim, 2013-06-01"


def test_set_get_and_bare_commands():
    link = open_link()
    assert link.set("v", 0.3) == pytest.approx(0.3)
    assert link.get("v") == pytest.approx(0.3)
    assert link.set("mode", 1) == 1
    assert link.command("home") is None
    assert link.get("tilt_homing_state") == 1
    assert link.get("button_data") == {"but0": 0, "but1": 0, "dial": 0}


@pytest.mark.parametrize("style", ["none", "labelled"])
def test_set_is_accepted_with_or_without_a_value_line(style):
    link = open_link(f"&set_reply={style}")
    echoed = link.set("v", 0.3)
    assert echoed is None if style == "none" else echoed == pytest.approx(0.3)
    assert link.get("v") == pytest.approx(0.3)


def test_board_errors_are_typed():
    link = open_link()
    with pytest.raises(UnknownNameError):
        link.get("nonsense")
    link.set("r", 1)
    link.set("p", 5)
    for _ in range(3):
        link.set("mode", 4)
        link.set("p", 1)
    link.set("mode", 4)
    with pytest.raises(QueueRolloverError):
        link.set("p", 1)
    assert link.get("v") == pytest.approx(0.6)  # the link carries on


def test_bulk_gives_a_motor_state_with_the_sign_of_cang_fixed():
    link = open_link()
    for name, value in (("r", 0), ("a", 0.5), ("v", 0.2), ("p", 90)):
        link.set(name, value)
    link.port.clock.advance(1.0)
    state = link.bulk()
    assert isinstance(state, MotorState)
    assert state.cang > 0  # positive set p, positive cang
    assert state.moving and not state.estop and not state.absolute
    assert state.imdl > 0 > state.imdr
    link.port.clock.advance(5.0)
    assert link.bulk().cang == pytest.approx(90.0, abs=1e-4)


def test_speed_is_compensated_for_the_left_wheel_quirk():
    link = open_link()
    for name, value in (
        ("r", 1000),
        ("a", 0.5),
        ("v", 0.4),
        ("vg", 0.3),
        ("vgr", 1),
        ("cdp", 5),
        ("p", 10),
    ):
        link.set(name, value)
    link.port.clock.advance(3.0)
    state = link.bulk()
    assert state.cvg == pytest.approx(0.3, abs=1e-6)
    assert state.gvr == pytest.approx(0.4 / 0.7, abs=1e-5)
    assert state.speed == pytest.approx(0.4, abs=1e-5)


def test_estop_flag():
    link = open_link()
    link.port.board.set_estop(True)
    assert link.bulk().estop


def test_observers_see_every_exchange_with_monotonic_times():
    link = open_link("&pace=1")
    seen: list[Exchange] = []
    link.add_observer(seen.append)
    link.set("v", 0.3)
    link.bulk()
    with pytest.raises(UnknownNameError):
        link.get("nonsense")
    assert [(e.kind, e.command) for e in seen] == [
        ("set", "set v 0.3"), ("get", "get bulk_data"), ("get", "get nonsense"),
    ]  # fmt: skip
    assert seen[0].value == pytest.approx(0.3)
    assert isinstance(seen[2].error, UnknownNameError)
    times = [t for e in seen for t in (e.sent_at, e.answered_at)]
    assert times == sorted(times)
    bulk_bytes = len("get bulk_data\r") + len(seen[1].lines[0]) + len("\r\nOK >\r\n")
    assert seen[1].answered_at - seen[1].sent_at == pytest.approx(
        bulk_bytes * BYTE_TIME_S, rel=0.01
    )


def test_a_failing_observer_does_not_break_the_link():
    link = open_link()

    def broken(exchange: Exchange) -> None:
        raise RuntimeError("observer bug")

    link.add_observer(broken)
    assert link.get("v") == pytest.approx(0.6)


@pytest.mark.parametrize(("power_line", "power_cycled"), [("rts", True), ("dtr", False)])
def test_the_handshake_pulses_the_chosen_power_line(power_line, power_cycled):
    port = serial.serial_for_url("giraff-sim://?clock=virtual&power=rts", timeout=0.05)
    port.write(b"set r 1\rset p 5\r")
    port.clock.advance(2.0)
    link = BoardLink(port, clock=port.clock)
    version = link.handshake(power_line=power_line)
    # Only a power cycle makes the board greet (the greeting from before is dropped)...
    assert version == ("1.1.112p-sim, 2013-06-01" if power_cycled else None)
    # ...and stops the wheels.
    assert link.bulk().moving is not power_cycled


def test_a_board_that_restarted_between_commands_is_reported():
    link = open_link()
    link.set("v", 0.25)
    link.port.dtr = False  # a brown-out: the board loses power and comes back
    link.port.dtr = True
    with pytest.raises(BoardRebootedError):
        link.get("v")
    assert link.version == "1.1.112p-sim, 2013-06-01"
    assert link.get("v") == pytest.approx(0.6)  # in step again, settings back at power-up


def test_speed_is_unknown_when_gvr_is_infinite():
    link = open_link()
    for name, value in (
        ("r", 1000),
        ("a", 0.5),
        ("v", 0.4),
        ("vg", 1),
        ("vgr", 1),
        ("cdp", 5),
        ("p", 3),
    ):
        link.set(name, value)
    link.port.clock.advance(3.0)
    state = link.bulk()
    assert state.cvg == 1.0
    assert state.speed is None
