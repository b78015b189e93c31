"""The simulated board as a pyserial port: `serial.serial_for_url("giraff-sim://...")`.

Options go in the query string, for example `giraff-sim://?pace=1&imperfect=1&seed=3` or
`giraff-sim://?firmware=later&battery=0.3`:

| option          | values                   | meaning                                          |
|-----------------|--------------------------|--------------------------------------------------|
| clock           | real, virtual            | virtual: time passes only when a test advances it |
| pace            | 0, 1                     | delay bytes as a 115200-baud line would           |
| imperfect, seed | 0/1, integer             | the imperfection model, seeded                   |
| power           | dtr, rts, none           | the modem line that powers the board (wire-facts) |
| ca              | 0, 1                     | print `Ca>` before the banner                     |
| noise           | 0, 1                     | print garbage before the banner                   |
| hex             | lower, upper             | case of the hex digits in replies                 |
| set_reply       | value, none, labelled    | how a `set` is answered                           |
| trailing_comma  | 0, 1                     | end lists with a comma, as real boards do         |
| auto_home       | 0, 1                     | start homing the head at power-up                 |
| firmware        | thesis, later, giraff-x  | what the board runs (sim/firmware.py)             |
| battery         | 0 to 1                   | the battery's charge at power-on (default 1)      |
| wheel_base      | metres, e.g. 0.467       | the robot's real wheel base (default 0.499)       |

The port exposes `board` (a `GiraffBoard`) and `clock` for tests. Closing the port
leaves the board running, as a real board carries on when its driver goes away;
opening it again reaches the same board, which greets again.
"""

from __future__ import annotations

import math
import urllib.parse

from serial import PortNotOpenError, SerialBase, SerialException

from giraff_console.clock import Clock, RealClock, VirtualClock
from giraff_console.protocol.kinematics import WHEEL_BASE_M, WHEEL_BASE_RANGE_M
from giraff_console.sim.board import BoardConfig, GiraffBoard
from giraff_console.sim.firmware import DEFAULT_FIRMWARE, firmware_named
from giraff_console.sim.imperfections import Imperfections
from giraff_console.sim.line import BoardLine

SCHEME = "giraff-sim"
BOOT_NOISE = b"\x00\xfe\x13#G\x7f~noise\r\n"
_FLAGS = ("0", "1")


class Serial(SerialBase):
    """A pyserial port with a simulated Giraff board on the other end."""

    # Set by SerialBase, which has no type information.
    is_open: bool

    def __init__(self, *args, **kwargs) -> None:
        self.board: GiraffBoard | None = None
        self.clock: Clock = RealClock()
        self._line: BoardLine | None = None
        self._power_line = "dtr"
        self._powered = False
        self._paced = False
        super().__init__(*args, **kwargs)

    # -- opening ------------------------------------------------------------------------

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        if self.board is None:
            config, paced = self.from_url(self._port)
            self.board = GiraffBoard(self.clock, config)
            self._paced = paced
        # Reopening reaches the same board, still running: a cable unplugged and back.
        self._line = BoardLine(self.board, self._paced)
        self.is_open = True
        self._powered = False
        self._update_power()

    def from_url(self, url: str) -> tuple[BoardConfig, bool]:
        """Parse the options of a `giraff-sim://` URL (see the module's table)."""
        parts = urllib.parse.urlsplit(url)
        if parts.scheme != SCHEME:
            raise SerialException(f"expected a {SCHEME}:// URL, got {url!r}")
        try:
            options = {k: v[-1] for k, v in urllib.parse.parse_qs(parts.query, True).items()}
            unknown = set(options) - {
                "clock", "pace", "imperfect", "seed", "power", "ca", "noise",
                "hex", "set_reply", "trailing_comma", "auto_home", "firmware", "battery",
                "wheel_base",
            }  # fmt: skip
            if unknown:
                raise ValueError(f"unknown option {sorted(unknown)[0]!r}")
            self.clock = _choice(options, "clock", {"real": RealClock, "virtual": VirtualClock})()
            self._power_line = _choice(
                options, "power", {"dtr": "dtr", "rts": "rts", "none": "none"}
            )
            seed = int(options["seed"]) if "seed" in options else None
            imperfections = (
                Imperfections.realistic(seed) if _flag(options, "imperfect") else Imperfections()
            )
            config = BoardConfig(
                calibration_line=_flag(options, "ca"),
                boot_noise=BOOT_NOISE if _flag(options, "noise") else b"",
                hex_upper=_choice(options, "hex", {"lower": False, "upper": True}),
                set_reply=_choice(
                    options, "set_reply", {"value": "value", "none": "none", "labelled": "labelled"}
                ),
                list_trailing_comma=_flag(options, "trailing_comma", default=True),
                auto_home=_flag(options, "auto_home"),
                imperfections=imperfections,
                firmware=firmware_named(options.get("firmware", DEFAULT_FIRMWARE)),
                battery=_number(options, "battery", 1.0, 0.0, 1.0),
                wheel_base=_number(options, "wheel_base", WHEEL_BASE_M, *WHEEL_BASE_RANGE_M),
            )
            return config, _flag(options, "pace")
        except ValueError as error:
            raise SerialException(f"bad {SCHEME}:// URL {url!r}: {error}") from None

    def close(self) -> None:
        self.is_open = False
        self._line = None

    # -- modem lines: the board powers up when its line is raised (A.3, wire-facts) -----

    def _update_power(self) -> None:
        if not self.is_open or self._line is None:
            return
        wanted = {"dtr": self._dtr_state, "rts": self._rts_state, "none": True}[self._power_line]
        if wanted and not self._powered:
            self._line.power_on(self.clock.now())
        elif not wanted and self._powered:
            self._line.power_off()
        self._powered = bool(wanted)

    def _update_dtr_state(self) -> None:
        self._update_power()

    def _update_rts_state(self) -> None:
        self._update_power()

    def _update_break_state(self) -> None:
        pass

    def _reconfigure_port(self, *args, **kwargs) -> None:
        pass

    @property
    def cts(self) -> bool:
        return self._powered

    @property
    def dsr(self) -> bool:
        return self._powered

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return self._powered

    # -- data ---------------------------------------------------------------------------

    def _open_line(self) -> BoardLine:
        if not self.is_open or self._line is None:
            raise PortNotOpenError()
        return self._line

    @property
    def in_waiting(self) -> int:
        line = self._open_line()
        now = self.clock.now()
        line.pump(now)
        return line.to_host.available(now)

    def write(self, data: bytes) -> int:
        line = self._open_line()
        if self._powered:
            now = self.clock.now()
            line.receive(bytes(data), now)
            line.pump(now)
        return len(data)

    def read(self, size: int = 1) -> bytes:
        """Up to `size` bytes, waiting on the port's clock for at most `timeout`."""
        line = self._open_line()
        deadline = None if self._timeout is None else self.clock.now() + self._timeout
        data = bytearray()
        while True:
            now = self.clock.now()
            line.pump(now)
            data += line.to_host.pop_due(now, size - len(data))
            if len(data) >= size or (deadline is not None and now >= deadline):
                return bytes(data)
            upcoming = line.next_event(whole_lines=False)
            if upcoming is None:
                if deadline is None:
                    # Nothing is in flight, so nothing more will come: do not hang.
                    return bytes(data)
                upcoming = deadline
            self.clock.sleep(max(0.0, min(upcoming, deadline or upcoming) - now))

    def reset_input_buffer(self) -> None:
        self._open_line().to_host.clear()

    def reset_output_buffer(self) -> None:
        self._open_line().to_board.clear()


def _flag(options: dict[str, str], name: str, default: bool = False) -> bool:
    if name not in options:
        return default
    if options[name] not in _FLAGS:
        raise ValueError(f"{name} must be 0 or 1")
    return options[name] == "1"


def _choice(options: dict[str, str], name: str, choices: dict):
    value = options.get(name, next(iter(choices)))
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}")
    return choices[value]


def _number(options: dict[str, str], name: str, default: float, low: float, high: float) -> float:
    if name not in options:
        return default
    try:
        value = float(options[name])
    except ValueError:
        value = math.nan
    if not low <= value <= high:
        raise ValueError(f"{name} must be a number from {low:g} to {high:g}")
    return value
