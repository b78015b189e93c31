"""A simulated Giraff motor board: text commands in, the board's replies out (A.3-A.4).

`GiraffBoard` knows nothing of serial ports; the in-process pyserial handler and the
pseudo-terminal server both feed it command lines and send back what it answers. Its
ground truth (`true_pose`, `battery_level`) is for tests and the synthetic camera, never
for the wire. It runs the thesis's firmware or a later one (sim/firmware.py).
"""

from __future__ import annotations

import math
import re
import threading
from dataclasses import dataclass, field
from typing import Literal

from giraff_console.clock import Clock
from giraff_console.protocol.charger import PARAMETERS as CHARGER_PARAMETERS
from giraff_console.protocol.charger import format_charger
from giraff_console.protocol.codec import FLOAT32_MAX, TWM_SETTINGS, encode_float, encode_int
from giraff_console.protocol.framing import CALIBRATION_LINE, LINE_END, PROMPT
from giraff_console.protocol.kinematics import WHEEL_BASE_M
from giraff_console.protocol.mode import WRITABLE_MODE_MASK
from giraff_console.sim.battery import Battery
from giraff_console.sim.collision import Solids
from giraff_console.sim.drive import Drive, MoveRefused, TruePose
from giraff_console.sim.firmware import DEFAULT_FIRMWARE, FIRMWARES, Firmware
from giraff_console.sim.head import Head
from giraff_console.sim.imperfections import ImperfectionModel, Imperfections
from giraff_console.sim.odometers import ENCODER_MODULUS, WheelCounters
from giraff_console.sim.stalk import STALK_RANGE, Stalk

SetReply = Literal["value", "none", "labelled"]

# The board reads plain decimals only; exponent notation is refused (see codec.format_number).
_PLAIN_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)\Z", re.ASCII)
_MOVE_PARAMETERS = ("v", "a", "r", "p", "vg", "vgr", "cdp")
_ENCODERS = ("enc0", "enc1")  # left, right
# The robot charges within this distance and heading of the dock's pose (assumption:
# the contacts are a few centimetres wide).
DOCK_REACH_M = 0.05
DOCK_REACH_DEG = 5.0


@dataclass(frozen=True)
class BoardConfig:
    """How the simulated board presents itself; the defaults follow the thesis (B.2).

    Real boards differ in small ways (wire-facts): a `Ca>` line or other noise before
    the banner, upper-case hex, a `set` answered with nothing or with `New Value: ...`.
    `firmware` chooses what the board can do and its banner; `wheel_base` is the robot's
    real distance between the wheels, which the firmware does not know (it drives by
    0.499 m); `battery` is the charge at power-on, 0 to 1 (later firmware only).
    """

    firmware: Firmware = FIRMWARES[DEFAULT_FIRMWARE]
    wheel_base: float = WHEEL_BASE_M
    battery: float = 1.0
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
        self.firmware = self.config.firmware
        self._imperfections = ImperfectionModel(self.config.imperfections)
        now = clock.now()
        # The battery and the stalk are hardware: they keep their state without power.
        self.battery = Battery(self.config.battery, now)
        self.stalk = Stalk(now)
        # Where the robot charges: set by whoever puts it in a building (sim_site).
        self.dock: TruePose | None = None
        # What the robot cannot drive through: also set by whoever puts it in a building.
        self._solids: Solids | None = None
        self._power_up(TruePose())

    def _power_up(self, pose: TruePose) -> None:
        now = self.clock.now()
        self.drive = Drive(
            self._imperfections, now, self.firmware, self.config.wheel_base, self._solids
        )
        self.drive.pose = pose
        self.head = Head(self.config.homing_seconds, self.config.tilt_speed, now)
        if self.config.auto_home or self.firmware.homes_at_power_up:
            self.head.home(now)
        self.buttons = [0, 0]
        self.dial = 0
        self.counters = WheelCounters(self.firmware.incremental_odometers)
        self._charger_turn = 0
        self._travel_seen = 0.0

    def _advance(self, now: float) -> None:
        """Bring the wheels, and the battery they draw on, up to clock time `now`."""
        drive = self.drive
        drive.advance(now)
        travel, self._travel_seen = drive.wheel_travel - self._travel_seen, drive.wheel_travel
        self.battery.update(now, travel, self._docked(), drive.wheel_speed())

    def _docked(self) -> bool:
        dock, pose = self.dock, self.drive.pose
        if dock is None:
            return False
        turn = math.remainder(pose.heading - dock.heading, math.tau)
        return (
            math.hypot(pose.x - dock.x, pose.y - dock.y) <= DOCK_REACH_M
            and abs(math.degrees(turn)) <= DOCK_REACH_DEG
        )

    # -- power and greeting -----------------------------------------------------------

    def greeting(self) -> bytes:
        """What the board prints when it powers up (A.3), noise and all."""
        lines = [f"# Giraf {self.firmware.version}, {self.firmware.date}", PROMPT]
        if self.config.calibration_line:
            lines.insert(0, CALIBRATION_LINE)
        text = b"".join(line.encode("ascii") + LINE_END for line in lines)
        return self.config.boot_noise + text

    def power_off(self) -> None:
        """Cut the board's power: the wheels stop dead and every setting is lost."""
        with self._lock:
            now = self.clock.now()
            self._advance(now)
            self.stalk.halt(now)
            self._power_up(self.drive.pose)

    # -- the wire -----------------------------------------------------------------------

    def execute(self, line: str) -> bytes:
        """Run one command line (without its CR) and return the reply and prompt."""
        with self._lock:
            now = self.clock.now()
            self._advance(now)
            words = line.split()
            reply: str | None = None
            if words:
                op = words[0]
                if op in ("set", "get") and len(words) < 2:
                    reply = "Error: Argument wasn't optional"
                elif op == "set" and words[1] == "twm" and self.firmware.twm:
                    reply = self._set_twm(words[2:], now)
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

    def _settable(self) -> tuple[str, ...]:
        names: tuple[str, ...] = (*_MOVE_PARAMETERS, "mode", "undock", "tilt_angle_from_home")
        if self.firmware.encoders:
            names += _ENCODERS
        if self.firmware.stalk:
            names += ("h",)
        return names

    def _set(self, name: str, text: str | None, now: float) -> str | None:
        if name not in self._settable():
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
        if name in _ENCODERS:
            if not 0 <= value < ENCODER_MODULUS:
                return "Error: Argument out of range"
            wheel = _ENCODERS.index(name)
            self.counters.set_encoder(wheel, self._wheel_totals()[wheel], int(value))
            return self._echo(self._int(int(value)))
        if name == "h":
            if not STALK_RANGE[0] <= value <= STALK_RANGE[1]:
                return "Error: Argument out of range"
            # A fraction is dropped, as a C conversion to an integer does (assumption).
            self.stalk.move_to(int(value), now)
            return self._echo(self._int(int(value)))
        if name in _MOVE_PARAMETERS:
            setattr(drive.next, name, value)
        refused = self._queue(name, value, now)
        if refused:
            return refused
        if name == "tilt_angle_from_home":
            self.head.set_tilt(value, now)
        return self._echo(self._float(value))

    def _queue(self, name: str, value: float, now: float, curved: bool = False) -> str | None:
        """Queue the move that `set p` or `set undock` asks for; the error, if any.
        `curved`: a curved move whatever `r` is (`twm`)."""
        drive = self.drive
        try:
            if name == "p" and not drive.queue_move(now, curved):
                return "ERROR: Queue rollover"
            if name == "undock" and not drive.queue_undock(value, now):
                return "ERROR: Queue rollover"
        except MoveRefused:
            return "Error: Argument out of range"
        return None

    def _set_twm(self, texts: list[str], now: float) -> str | None:
        """Giraff-X's `set twm vg cdp vgr v p 0`: sets vg, cdp, vgr and v, then queues the
        move as `set p` would, with the board's a and mode, but always as a curved move
        (r > 50) whatever the board's r: a deployed driver sends its curves with `twm`
        after a stop idiom that left r = 50, and its robot still curves (wire-facts "What
        the deployed drivers do"). The board's r itself is not changed. Answered with the
        prompt alone (assumption: no source shows its answer). What the closing 0 means is
        not documented; drivers always send 0, and anything else is refused."""
        if len(texts) < len(TWM_SETTINGS) + 1:
            return "Error: Argument wasn't optional"
        if len(texts) > len(TWM_SETTINGS) + 1 or not all(map(_PLAIN_DECIMAL.match, texts)):
            return "Error: Unknown argument"
        values = [float(text) for text in texts]
        if any(abs(value) > FLOAT32_MAX for value in values):
            return "Error: Argument out of range"
        if values[-1] != 0:
            return "Error: Unknown argument"
        for name, value in zip(TWM_SETTINGS, values[:-1], strict=True):
            setattr(self.drive.next, name, value)
        return self._queue("p", values[-2], now, curved=True)

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
        later = self._get_later(name, now)
        if later is not None:
            return later
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

    def _get_later(self, name: str, now: float) -> str | None:
        """A reading only later firmware has; None when this board has no such name."""
        firmware = self.firmware
        if firmware.encoders and name in _ENCODERS:
            wheel = _ENCODERS.index(name)
            return self._int(self.counters.encoder(wheel, self._wheel_totals()[wheel]))
        if firmware.stalk and name == "h":
            return self._int(self.stalk.reading(now))
        if firmware.charger and name == "charger_data":
            # One parameter per read, in turn (wire-facts "Battery").
            parameter = CHARGER_PARAMETERS[self._charger_turn]
            self._charger_turn = (self._charger_turn + 1) % len(CHARGER_PARAMETERS)
            battery = self.battery
            return format_charger(battery.status, parameter, battery.reading(parameter))
        if firmware.twm and name == "twm":
            staged = self.drive.next
            return self._list(**{key: self._float(getattr(staged, key)) for key in TWM_SETTINGS})
        return None

    def _wheel_totals(self) -> tuple[float, float]:
        return self.drive.left_odometer, self.drive.right_odometer

    def _bulk(self, now: float) -> str:
        """All eight fields, in the order real boards send them (wire-facts)."""
        drive = self.drive
        imdl, imdr = self.counters.odometers(*self._wheel_totals())
        return self._list(
            cang=self._float(drive.reported_cang()),
            cdis=self._float(drive.reported_cdis()),
            gvr=self._float(drive.reported_gvr()),
            tilt_angle_from_home=self._float(self.head.angle(now)),
            imdl=self._float(imdl),
            imdr=self._float(imdr),
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
            self._advance(self.clock.now())
            return self.drive.pose

    @property
    def battery_level(self) -> float:
        """The battery's charge now, 0 (empty) to 1 (full). Tests only: the wire has
        `charger_data` on later firmware, and nothing on the thesis's."""
        with self._lock:
            self._advance(self.clock.now())
            return self.battery.level

    def place(self, pose: TruePose) -> None:
        """Put the robot down at `pose`, as a person carrying it would: the odometers
        do not notice. Where a floor plan says the robot starts."""
        with self._lock:
            now = self.clock.now()
            self._advance(now)
            self.drive.pose = pose
            # Set down on the dock, it charges from now on.
            self.battery.update(now, 0.0, self._docked(), 0.0)

    def make_solid(self, solids: Solids | None) -> None:
        """Walls and obstacles the robot stops against (sim/collision.py), from now on;
        None for open space, the default. They outlast a power cut: they are the
        building's, not the board's."""
        with self._lock:
            self._advance(self.clock.now())
            self._solids = solids
            self.drive.solids = solids

    @property
    def solids(self) -> Solids | None:
        return self._solids

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
