"""The control loop on later boards: battery and stalk in the telemetry, faults in their
reads reported once, and Giraff-X's curves as one twm (issue 13)."""

from __future__ import annotations

import pytest

from giraff_console.link import BoardLink
from giraff_console.protocol.errors import ProtocolError
from giraff_console.robot.board_gauges import READ_EVERY_S
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.telemetry import Telemetry
from giraff_console.robot.teleop import Teleop
from tests.listening import notes_into, only

TICK = 0.05


class Console:
    def __init__(self, firmware: str) -> None:
        self.link = BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}&battery=0.6")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.sent: list[str] = []
        self.link.add_observer(lambda exchange: self.sent.append(exchange.command))
        self.reports: list[str] = []
        self.published: list[Telemetry] = []
        self.loop = ControlLoop(lambda: self.link, teleop=Teleop(), deadman=Deadman(self.clock),
                                clock=self.clock)  # fmt: skip
        self.loop.subscribe(notes_into(self.reports))
        self.loop.subscribe(only(Telemetry, self.published.append))

    def run(self, seconds: float, intent: Intent | None = None) -> None:
        end = self.clock.now() + seconds
        while self.clock.now() < end - 1e-9:
            if intent is not None:
                self.loop.press(intent)
            self.loop.tick()
            self.clock.advance(TICK)


def test_a_later_board_s_battery_and_stalk_reach_the_telemetry():
    console = Console("later")
    console.run(4.0)  # six charger reads: every parameter once
    telemetry = console.published[-1]
    assert telemetry.board is not None and telemetry.board.charger
    assert telemetry.battery is not None
    assert telemetry.battery.percent == pytest.approx(60, abs=2)
    assert telemetry.battery.voltage is not None and not telemetry.battery.charging
    assert telemetry.stalk is not None and 0 <= telemetry.stalk <= 1000
    reads = console.sent.count("get charger_data")
    assert 4.0 / READ_EVERY_S - 1 <= reads <= 4.0 / READ_EVERY_S + 1


def test_the_thesis_board_has_neither_and_is_not_asked():
    console = Console("thesis")
    console.run(2.0)
    telemetry = console.published[-1]
    assert telemetry.board is not None and not telemetry.board.later_firmware
    assert (telemetry.battery, telemetry.stalk) == (None, None)
    assert console.sent.count("get charger_data") == 1  # the probe's, answered Unknown name
    assert "get h" not in console.sent[console.sent.index("get twm") + 1 :]


def test_a_garbled_charger_line_is_reported_once_and_driving_goes_on(monkeypatch):
    console = Console("later")
    console.run(TICK)

    def garbled(*, automatic: bool = False):
        raise ProtocolError("charger line garbled: 'S:S#4,B:F#zz'")

    monkeypatch.setattr(console.link, "charger", garbled)
    console.run(3.0, Intent.FORWARD)
    failures = [r for r in console.reports if r.startswith("get charger_data failed")]
    assert len(failures) == 1
    assert console.board.true_pose.x > 0.5  # it drove on
    assert console.published[-1].stalk is not None
    monkeypatch.undo()
    console.run(1.0)
    assert "get charger_data answers again" in console.reports


def test_giraff_x_takes_a_curve_as_one_twm_and_the_later_board_as_separate_sets():
    for firmware, twm in (("giraff-x", True), ("later", False)):
        console = Console(firmware)
        console.run(TICK)
        console.sent.clear()
        console.run(2.0, Intent.FORWARD_LEFT)
        assert any(c.startswith("set twm ") for c in console.sent) == twm
        assert any(c.startswith("set vg ") for c in console.sent) != twm
        assert console.board.true_pose.heading > 0.2
        assert not any("refused" in r for r in console.reports), console.reports
