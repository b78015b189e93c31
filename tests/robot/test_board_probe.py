"""The probe: which board answers, told from what it answers to (issue 13)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from giraff_console.cli.main import main
from giraff_console.link import BoardFeatures, BoardLink, Exchange, probe
from tests.link.scripted import ScriptedBoard, well_behaved

TIMEOUT = 0.3


def open_board(firmware: str) -> BoardLink:
    return BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}")


@pytest.mark.parametrize(("firmware", "expected"), [
    ("thesis", (False, False, False, False)),
    ("later", (True, True, True, False)),
    ("giraff-x", (True, True, True, True)),
])  # fmt: skip
def test_the_probe_tells_the_profiles_apart_without_reading_bulk_data(firmware, expected):
    link = open_board(firmware)
    seen: list[Exchange] = []
    link.add_observer(seen.append)
    features = probe(link)
    assert (features.encoders, features.stalk, features.charger, features.twm) == expected
    assert features.later_firmware == (firmware != "thesis")
    assert features.version == link.version
    assert [e.command for e in seen] == ["get enc0", "get h", "get charger_data", "get twm"]
    assert all(e.automatic for e in seen)  # the console's own: not in the transcript
    line = features.describe()
    assert line.startswith(f"board {link.version}: ")
    assert ("later firmware" in line) == (firmware != "thesis")
    reading = "totals" if firmware == "thesis" else "increments"
    assert line.endswith(f"imdl/imdr read as {reading}")


@pytest.fixture
def scripted(pty_pair):
    master, path = pty_pair
    boards: list[ScriptedBoard] = []

    def start(answer) -> tuple[ScriptedBoard, BoardLink]:
        board = ScriptedBoard(master, answer)
        board.start()
        boards.append(board)
        return board, BoardLink.open(path, timeout=TIMEOUT, handshake_timeout=0.1)

    yield start
    for board in boards:
        board.stop()


def test_an_error_line_means_the_board_knows_the_name_and_a_garbled_one_is_not_relied_on(
    scripted,
):
    def answer(command: str) -> bytes | None:
        if command == "get enc0":
            return b"Error: Argument out of range\r\nOK >\r\n"
        if command == "get charger_data":
            return b"S:S#4,B:F#zz U#0000\r\nOK >\r\n"
        if command in ("get h", "get twm"):
            return f"Unknown name: {command.split()[1]}\r\nOK >\r\n".encode()
        return well_behaved(command)

    board, link = scripted(answer)
    try:
        features = probe(link)
    finally:
        link.close()
    assert (features.encoders, features.stalk, features.charger, features.twm) == (
        True, False, False, False,
    )  # fmt: skip
    assert features.version is None  # a pty: no greeting
    assert "get bulk_data" not in board.commands
    assert features.describe("encoders") == (
        "board version unknown: later firmware (encoders); odometry from the wheel encoders"
    )


def test_the_thesis_board_is_described_as_such():
    features = BoardFeatures("1.1.112p, 2013-06-01", False, False, False, False)
    assert not features.later_firmware
    assert features.describe() == (
        "board 1.1.112p, 2013-06-01: the thesis's firmware; imdl/imdr read as totals"
    )


def test_a_height_stalk_alone_does_not_make_a_later_board():
    # Some units of any firmware have one (wire-facts): their imdl/imdr stay totals.
    features = BoardFeatures("1.1.112p, 2013-06-01", False, True, False, False)
    assert not features.later_firmware
    assert features.describe() == (
        "board 1.1.112p, 2013-06-01: the thesis's firmware, with a height stalk; imdl/imdr "
        "read as totals"
    )


@pytest.mark.parametrize("feature", ["encoders", "charger", "twm"])
def test_encoders_a_charger_or_twm_make_a_later_board(feature):
    features = replace(BoardFeatures(None, False, False, False, False), **{feature: True})
    assert features.later_firmware
    assert features.describe().endswith("imdl/imdr read as increments")


def test_twm_chosen_otherwise_than_the_probe_found_is_said():
    giraff_x = BoardFeatures(None, True, True, True, True)
    assert giraff_x.describe(twm=True) == giraff_x.describe()
    assert giraff_x.describe(twm=False).endswith("; twm not used, as the settings say")
    later = replace(giraff_x, twm=False)
    assert later.describe(twm=True).endswith("; curves as one twm, as the settings say")


def test_send_says_which_board_answered_on_standard_error_only(capsys):
    assert main(["send", "--port", "giraff-sim://?firmware=later", "get v"]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[0] == "> get v"
    assert "board" not in out
    assert err.strip() == (
        "giraff-console: board 1.4.226-sim, 2015-09-14: later firmware (encoders, height "
        "stalk, charger); imdl/imdr read as increments"
    )
