"""The battery and the height stalk of later boards, read every half second (issue 13).

A later board reports its charger with `get charger_data`, one parameter per read in
turn (protocol/charger.py, robot/battery.py), and its stalk's height with `get h`
(wire-facts, "Later firmware"). The control loop reads each every READ_EVERY_S while it
polls, as automatic traffic, after the tick's driving. Neither may stop the driving: a
read that fails, or a garbled charger line, is reported once (not twenty times a
second) and tried again at the next turn; only a lost link or a restarted board, which
the loop handles, pass through.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from giraff_console.link import BoardFeatures, BoardLink
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import BoardError, BoardRebootedError, ProtocolError
from giraff_console.robot.battery import Battery, BatteryGauge

READ_EVERY_S = 0.5


class BoardGauges:
    """The latest battery and stalk readings of the board the loop is connected to."""

    def __init__(self, report: Callable[[str], None] = lambda message: None) -> None:
        self.report = report
        self.features: BoardFeatures | None = None
        self.stalk: int | None = None
        self._gauge = BatteryGauge()
        self._due = 0.0
        self._failing: set[str] = set()

    @property
    def battery(self) -> Battery | None:
        return self._gauge.battery

    def connected(self, features: BoardFeatures) -> None:
        """A new board (or the same one again): nothing is known of it yet."""
        self.features = features
        self.stalk = None
        self._gauge = BatteryGauge()
        self._due = 0.0
        self._failing.clear()

    def disconnected(self) -> None:
        self.features = None
        self.stalk = None
        self._gauge = BatteryGauge()

    def poll(self, link: BoardLink, now: float) -> None:
        """Read what the board has, if it is time to."""
        features = self.features
        if features is None or now < self._due:
            return
        self._due = now + READ_EVERY_S
        if features.charger:
            self._read("charger_data", lambda: self._gauge.update(link.charger(automatic=True)))
        if features.stalk:
            self._read("h", lambda: self._stalk(link))

    def _stalk(self, link: BoardLink) -> None:
        value = link.send(Command("get", "h"), automatic=True).value
        if not isinstance(value, int | float) or not math.isfinite(value):
            raise ProtocolError(f"get h answered {value!r}, not a height")
        self.stalk = round(value)

    def _read(self, name: str, read: Callable[[], object]) -> None:
        try:
            read()
        except BoardRebootedError:
            raise
        except (BoardError, ProtocolError) as error:
            if name not in self._failing:
                self._failing.add(name)
                self.report(f"get {name} failed: {error}; the console keeps trying quietly")
            return
        if name in self._failing:
            self._failing.discard(name)
            self.report(f"get {name} answers again")
