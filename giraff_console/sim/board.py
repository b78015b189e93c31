"""A simulated Giraff motor board: text commands in, the board's replies out (A.3-A.4).

`GiraffBoard` knows nothing of serial ports; the in-process pyserial handler and the
pseudo-terminal server both feed it command lines and send back what it answers. Its
ground truth (`true_pose`) is for tests and the synthetic camera, never for the wire.
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass, field
from typing import Literal

from giraff_console.clock import Clock
from giraff_console.protocol.codec import FLOAT32_MAX, encode_float, encode_int
from giraff_console.protocol.framing import CALIBRATION_LINE, LINE_END, PROMPT
from giraff_console.protocol.mode import WRITABLE_MODE_MASK
from giraff_console.sim.drive import Drive, MoveRefused, TruePose
from giraff_console.sim.head import Head
from giraff_console.sim.imperfections import ImperfectionModel, Imperfections

SetReply = Literal["value", "none", "labelled"]

# The board reads plain decimals only; exponent notation is refused (see codec.format_number).
_PLAIN_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)\Z", re.ASCII)
_MOVE_PARAMETERS = ("v", "a", "r", "p", "vg", "vgr", "cdp")


@dataclass(frozen=True)
class BoardConfig:
    """How the simulated board presents itself; the defaults follow the thesis (B.2).

    Real boards differ in small ways (wire-facts): a `Ca>` line or other noise before
    the banner, upper-case hex, a `set` answered with nothing or with `New Value: ...`.
    """

    version: str = "1.1.112p-sim"
    date: str = "2013-06-01"
    calibration_line: bool = False
    hex_upper: bool = False
    set_reply: SetReply = "value"
    list_trailing_comma: bool = True
    auto_home: bool = False
    boot_noise: bytes = b""
    homing_seconds: float = 3.0
    tilt_speed: float = 0.5
    imperfections: Imperfections = field(default_factory=Imperfections)


class GiraffBoard:
    """The board's command interpreter, state and ground truth; thread-safe."""

    def __init__(self, clock: Clock, config: BoardConfig | None = None) -> None:
        self.clock = clock
        self.config = config or BoardConfig()
        self._lock = threading.RLock()
        self._imperfections = ImperfectionModel(self.config.imperfections)
        self._power_up(TruePose())

    def _power_up(self, pose: TruePose) -> None:
        now = self.clock.now()
        self.drive = Drive(self._imperfections, now)
        self.drive.pose = pose
        self.head = Head(self.config.homing_seconds, self.config.tilt_speed, now)
        if self.config.auto_home:
            self.head.home(now)
        self.buttons = [0, 0]
        self.dial = 0

    # -- power and greeting -----------------------------------------------------------

    def greeting(self) -> bytes:
        """What the board prints when it powers up (A.3), noise and all."""
        lines = [f"# Giraf {self.config.version}, {self.config.date}", PROMPT]
        if self.config.calibration_line:
            lines.insert(0, CALIBRATION_LINE)
        text = b"".join(line.encode("ascii") + LINE_END for line in lines)
        return self.config.boot_noise + text

    def power_off(self) -> None:
        """Cut the board's power: the wheels stop dead and every setting is lost."""
        with self._lock:
            self.drive.advance(self.clock.now())
            self._power_up(self.drive.pose)

    # -- the wire -----------------------------------------------------------------------

    def execute(self, line: str) -> bytes:
        """Run one command line (without its CR) and return the reply and prompt."""
        with self._lock:
            now = self.clock.now()
            self.drive.advance(now)
            words = line.split()
            reply: str | None = None
            if words:
                op = words[0]
                if op in ("set", "get") and len(words) < 2:
                    reply = "Error: Argument wasn't optional"
                elif op == "set":
                    reply = self._set(words[1], words[2] if len(words) > 2 else None, now)
                elif op == "get":
                    reply = self._get(words[1], now)
                elif op == "home":
                    self.head.home(now)
                else:
                    reply = f"Unknown name: {op}"
            text = PROMPT if reply is None else f"{reply}\r\n{PROMPT}"
            return text.encode("ascii", "replace") + LINE_END

    def _hex_case(self, text: str) -> str:
        return text[:2] + text[2:].upper() if self.config.hex_upper else text

    def _float(self, value: float) -> str:
        return self._hex_case(encode_float(value))

    def _int(self, value: int) -> str:
        return self._hex_case(encode_int(value))

    def _set(self, name: str, text: str | None, now: float) -> str | None:
        known = (*_MOVE_PARAMETERS, "mode", "undock", "tilt_angle_from_home")
        if name not in known:
            return f"Unknown name: {name}"
        if text is None:
            return "Error: Argument wasn't optional"
        if not _PLAIN_DECIMAL.match(text):
            return "Error: Unknown argument"
        value = float(text)
        if abs(value) > FLOAT32_MAX:
            return "Error: Argument out of range"
        drive = self.drive
        if name == "mode":
            bits = int(value) & WRITABLE_MODE_MASK
            drive.next.mode = bits
            return self._echo(self._int(bits))
        if name in _MOVE_PARAMETERS:
            setattr(drive.next, name, value)
        try:
            if name == "p" and not drive.queue_move(now):
                return "ERROR: Queue rollover"
            if name == "undock" and not drive.queue_undock(value, now):
                return "ERROR: Queue rollover"
        except MoveRefused:
            return "Error: Argument out of range"
        if name == "tilt_angle_from_home":
            self.head.set_tilt(value, now)
        return self._echo(self._float(value))

    def _echo(self, encoded: str) -> str | None:
        if self.config.set_reply == "none":
            return None
        if self.config.set_reply == "labelled":
            return f"New Value: {encoded}"
        return encoded

    def _get(self, name: str, now: float) -> str:
        drive = self.drive
        if name == "bulk_data":
            return self._bulk(now)
        if name in _MOVE_PARAMETERS:
            return self._float(getattr(drive.next, name))
        readings = {
            "mode": lambda: self._int(drive.mode_bits()),
            "cdis": lambda: self._float(drive.reported_cdis()),
            "cang": lambda: self._float(drive.reported_cang()),
            "gvr": lambda: self._float(drive.reported_gvr()),
            "cvg": lambda: self._float(drive.cvg),
            "tilt_homing_state": lambda: self._int(self.head.homing_state(now)),
            "tilt_angle_from_home": lambda: self._float(self.head.angle(now)),
            "but0": lambda: self._int(self.buttons[0]),
            "but1": lambda: self._int(self.buttons[1]),
            "dial": lambda: self._int(self.dial),
            "button_data": lambda: self._list(
                but0=self._int(self.buttons[0]),
                but1=self._int(self.buttons[1]),
                dial=self._int(self.dial),
            ),
        }
        reading = readings.get(name)
        return reading() if reading else f"Unknown name: {name}"

    def _bulk(self, now: float) -> str:
        """All eight fields, in the order real boards send them (wire-facts)."""
        drive = self.drive
        return self._list(
            cang=self._float(drive.reported_cang()),
            cdis=self._float(drive.reported_cdis()),
            gvr=self._float(drive.reported_gvr()),
            tilt_angle_from_home=self._float(self.head.angle(now)),
            imdl=self._float(drive.left_odometer),
            imdr=self._float(drive.right_odometer),
            cvg=self._float(drive.cvg),
            mode=self._int(drive.mode_bits()),
        )

    def _list(self, **fields: str) -> str:
        text = ",".join(f"{name}:{value}" for name, value in fields.items())
        return text + "," if self.config.list_trailing_comma else text

    # -- the world outside the wire -----------------------------------------------------

    @property
    def true_pose(self) -> TruePose:
        """Where the robot really is. Tests and the synthetic camera only."""
        with self._lock:
            self.drive.advance(self.clock.now())
            return self.drive.pose

    def place(self, pose: TruePose) -> None:
        """Put the robot down at `pose`, as a person carrying it would: the odometers
        do not notice. Where a floor plan says the robot starts."""
        with self._lock:
            self.drive.advance(self.clock.now())
            self.drive.pose = pose

    def press_button(self, button: int) -> None:
        """Press the red (0) or green (1) button on the chassis."""
        with self._lock:
            self.buttons[button] += 1

    def turn_dial(self, steps: int) -> None:
        """Turn the dial by `steps`, negative for the other way."""
        with self._lock:
            self.dial += steps

    def set_estop(self, active: bool) -> None:
        """Raise or clear ESTOP as the wheel electronics would."""
        with self._lock:
            self.drive.set_estop(active, self.clock.now())

    def stall(self, seconds: float) -> None:
        """Block the wheels for `seconds` while the move stays commanded."""
        with self._lock:
            self.drive.stall(seconds, self.clock.now())
