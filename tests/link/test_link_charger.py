"""`BoardLink.charger`: a later board's charger over a real pty, and the simulator's."""

from __future__ import annotations

import pytest

from giraff_console.link import BoardLink, Exchange
from giraff_console.protocol import ProtocolError, UnknownNameError
from giraff_console.protocol.charger import (
    PARAMETERS,
    ChargerReading,
    ChargeStatus,
    format_charger,
)
from tests.link.scripted import ScriptedBoard, well_behaved

TIMEOUT = 0.3


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


def charger_board(lines: list[str]):
    """A board that answers `get charger_data` with `lines` in turn, round and round."""
    served = iter(lines * 10)

    def answer(command: str) -> bytes | None:
        if command == "get charger_data":
            return f"{next(served)}\r\nOK >\r\n".encode()
        return well_behaved(command)

    return answer


def test_each_read_gives_the_next_parameter(scripted):
    values = {"B": 25.5, "b": -1.5, "t": 30.0, "D": 0.0, "d": 0.0, "W": -1200}
    lines = [format_charger(ChargeStatus.NOT_DOCKED, p, v) for p, v in values.items()]
    _board, link = scripted(charger_board(lines))
    readings = [link.charger() for _ in PARAMETERS]
    assert readings == [ChargerReading(ChargeStatus.NOT_DOCKED, p, v) for p, v in values.items()]


def test_an_automatic_read_is_marked_so(scripted):
    line = format_charger(ChargeStatus.TRICKLE_CHARGING, "B", 27.0)
    _board, link = scripted(charger_board([line]))
    seen: list[Exchange] = []
    link.add_observer(seen.append)
    assert link.charger(automatic=True).status is ChargeStatus.TRICKLE_CHARGING
    assert seen[-1].automatic
    assert seen[-1].lines == (line,)
    assert seen[-1].value is None


def test_a_garbled_charger_line_is_a_protocol_error_and_the_line_stays_in_step(scripted):
    board, link = scripted(charger_board(["S:S#4,B:F#zzzz U#0000"]))
    seen: list[Exchange] = []
    link.add_observer(seen.append)
    with pytest.raises(ProtocolError):
        link.charger()
    assert isinstance(seen[-1].error, ProtocolError)  # the exchange records it
    before = len(board.commands)
    assert link.get("a") == pytest.approx(0.5)
    assert board.commands[before:] == ["get a"]


def test_a_reply_without_a_charger_line_is_a_protocol_error(scripted):
    _board, link = scripted()  # answers a bare prompt
    with pytest.raises(ProtocolError, match="no charger line"):
        link.charger()


def test_the_thesis_board_has_no_charger():
    link = BoardLink.open("giraff-sim://?clock=virtual")
    with pytest.raises(UnknownNameError):
        link.charger()


def test_the_link_reads_a_later_simulators_battery_sent_as_floats():
    # The simulator sends `W:F#` as the deployed drivers expect (wire-facts "What the
    # deployed drivers do"); the console's own link reads it as it read `W:I#`.
    link = BoardLink.open("giraff-sim://?clock=virtual&firmware=later&battery=0.4")
    readings = {reading.parameter: reading for reading in (link.charger() for _ in PARAMETERS)}
    assert readings["W"].value == pytest.approx(-0.6 * 327_360.0, abs=0.1)
    assert readings["W"].status is ChargeStatus.NOT_DOCKED
    link.close()
