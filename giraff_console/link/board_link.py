"""A Giraff motor board over any pyserial port or URL.

One request is in flight at a time: a command goes out only after the previous
command's `OK >` prompt (A.3). Every wait has a deadline. After anything that leaves
the line in doubt (a timeout, unexpected input, a board that rebooted) the link
resynchronises before the next command: it sends `get` of a parameter that cannot
exist, with a unique name, and discards everything up to the board's `Unknown name:`
answer for that name. A late reply can therefore never be paired with a later command,
one of the known failures of earlier drivers (wire-facts).
"""

from __future__ import annotations

import contextlib
import logging
import secrets
import threading

import serial

from giraff_console.clock import Clock, RealClock
from giraff_console.link.errors import LinkDisconnected, LinkError, LinkTimeout
from giraff_console.link.exchange import Exchange, ExchangeKind, Observer
from giraff_console.link.motor_state import MotorState
from giraff_console.protocol.charger import ChargerReading, parse_charger
from giraff_console.protocol.codec import Command, Number
from giraff_console.protocol.errors import (
    BoardRebootedError,
    GiraffError,
    ProtocolError,
    UnknownNameError,
)
from giraff_console.protocol.framing import (
    BAUD_RATE,
    CALIBRATION_LINE,
    banner_version,
    is_banner,
    is_prompt,
)
from giraff_console.protocol.replies import ReplyValue, parse_reply

log = logging.getLogger(__name__)

DEFAULT_TIMEOUT_S = 1.0
# How long a freshly powered board may take to greet.
HANDSHAKE_TIMEOUT_S = 2.0
# Drivers drop the power line, wait about 5 ms, then raise it (wire-facts).
POWER_PULSE_S = 0.005
# Longest wait inside one port read, so that deadlines are checked often enough.
_READ_SLICE_S = 0.05
# No reply line is this long; a longer run without a line end is noise.
_MAX_LINE_BYTES = 4096


class BoardLink:
    """Request/response access to one board; thread-safe."""

    def __init__(
        self,
        port: serial.SerialBase,
        *,
        timeout: float = DEFAULT_TIMEOUT_S,
        clock: Clock | None = None,
    ) -> None:
        self.port = port
        self.timeout = timeout
        self.clock = clock or RealClock()
        self.version: str | None = None
        self._lock = threading.RLock()
        self._buffer = bytearray()
        self._observers: list[Observer] = []
        self._needs_resync = True
        port.timeout = min(_READ_SLICE_S, timeout)

    @classmethod
    def open(
        cls,
        url: str,
        *,
        timeout: float = DEFAULT_TIMEOUT_S,
        power_line: str = "dtr",
        handshake_timeout: float = HANDSHAKE_TIMEOUT_S,
        clock: Clock | None = None,
    ) -> BoardLink:
        """Open a port or URL at 115200 8N1, power the board up and wait for it."""
        try:
            port = serial.serial_for_url(url, baudrate=BAUD_RATE, timeout=_READ_SLICE_S)
        except (serial.SerialException, OSError, ValueError) as error:
            raise LinkDisconnected(f"cannot open {url}: {error}") from None
        link = cls(port, timeout=timeout, clock=clock or getattr(port, "clock", None))
        try:
            link.handshake(power_line=power_line, timeout=handshake_timeout)
        except GiraffError:
            link.close()
            raise
        return link

    # -- observers ----------------------------------------------------------------------

    def add_observer(self, observer: Observer) -> None:
        """Call `observer` with every exchange. It runs on the link's thread: keep it quick."""
        self._observers.append(observer)

    def _notify(self, exchange: Exchange) -> None:
        for observer in list(self._observers):
            try:
                observer(exchange)
            except Exception:
                log.exception("link observer failed")

    # -- the typed API ------------------------------------------------------------------

    def set(self, name: str, value: Number) -> Number | None:
        """`set NAME VALUE`; returns the value the board echoed, if it echoed one."""
        value_back = self.send(Command("set", name, value)).value
        return value_back if not isinstance(value_back, dict) else None

    def get(self, name: str) -> ReplyValue:
        """`get NAME`: a number, or a dict for list replies."""
        exchange = self.send(Command("get", name))
        if exchange.value is None:
            raise ProtocolError(f"no value in the reply to get {name}")
        return exchange.value

    def command(self, name: str) -> None:
        """A bare command such as `home`."""
        self.send(Command("command", name))

    def bulk(self, *, automatic: bool = False) -> MotorState:
        """`get bulk_data` as a MotorState."""
        exchange = self.send(Command("get", "bulk_data"), automatic=automatic)
        if not isinstance(exchange.value, dict):
            raise ProtocolError(f"bulk_data reply is not a list: {exchange.lines!r}")
        return MotorState.from_bulk(exchange.value, exchange.answered_at)

    def charger(self, *, automatic: bool = False) -> ChargerReading:
        """`get charger_data` on a later board: the status and one parameter, which
        changes from read to read (wire-facts "Later firmware"). A thesis board answers
        `Unknown name` (UnknownNameError)."""
        exchange = self.send(Command("get", "charger_data"), automatic=automatic)
        if len(exchange.lines) != 1:
            raise ProtocolError(f"no charger line in the reply: {exchange.lines!r}")
        return parse_charger(exchange.lines[0])

    def send(self, command: Command, *, automatic: bool = False) -> Exchange:
        """Send one command and wait for its reply; raises the typed errors."""
        with self._lock:
            if self._needs_resync or self._unexpected_input():
                self._resync()
            return self._exchange(command.kind, command.text, command.wire, automatic)

    # -- connection ---------------------------------------------------------------------

    def handshake(
        self, *, power_line: str = "dtr", timeout: float = HANDSHAKE_TIMEOUT_S
    ) -> str | None:
        """Power the board up and wait for its greeting (A.3); returns the version.

        Noise and a `Ca>` line before the banner are skipped. A board that was already
        powered, or a port without modem lines (a pty), may not greet at all: then the
        link checks that a board answers at all, and the version stays unknown.
        """
        with self._lock:
            self._pulse_power(power_line)
            sent_at = self.clock.now()
            try:
                lines = self._read_until_prompt(sent_at + timeout)
            except LinkTimeout:
                self._resync()
                self.version = None
                return None
            banners = [line for line in lines if is_banner(line)]
            self.version = banner_version(banners[-1]) if banners else None
            self._needs_resync = False
            self._notify(
                Exchange("greeting", "", tuple(lines), None, None, sent_at, self.clock.now())
            )
            return self.version

    def _pulse_power(self, power_line: str) -> None:
        lines = {"dtr": ("dtr",), "rts": ("rts",), "both": ("dtr", "rts"), "none": ()}
        if power_line not in lines:
            raise ValueError(f"power line must be one of {', '.join(lines)}")
        try:
            for name in lines[power_line]:
                setattr(self.port, name, False)
            if lines[power_line]:
                # Whatever the board said before it lost power is history.
                self.port.reset_input_buffer()
                self.clock.sleep(POWER_PULSE_S)
            for name in lines[power_line]:
                setattr(self.port, name, True)
        except (OSError, serial.SerialException):
            # A pseudo-terminal has no modem lines; the board there is always powered.
            log.debug("port %s has no modem control lines", self.port.port)
        self._buffer.clear()

    def close(self) -> None:
        """Close the port. Stopping the robot first is the caller's business."""
        with self._lock, contextlib.suppress(OSError, serial.SerialException):
            self.port.close()

    # -- the wire -----------------------------------------------------------------------

    def _exchange(
        self, kind: ExchangeKind, text: str, wire: bytes, automatic: bool = False
    ) -> Exchange:
        sent_at = self.clock.now()
        lines: list[str] = []
        try:
            self._write(wire)
            lines = self._read_until_prompt(sent_at + self.timeout)
            reply = parse_reply(lines)
        except UnknownNameError as error:
            # The name asked for: the second word of a set or get (a twm has more).
            failure: GiraffError = error
            if error.name != text.split()[:2][-1]:
                # An answer to some other command: the line is out of step.
                self._needs_resync = True
                failure = ProtocolError(f"reply out of step: {error.line!r} to {text!r}")
            now = self.clock.now()
            self._notify(Exchange(kind, text, tuple(lines), None, failure, sent_at, now, automatic))
            raise failure from None
        except GiraffError as error:
            if isinstance(error, (LinkError, BoardRebootedError)):
                self._needs_resync = True
            now = self.clock.now()
            self._notify(Exchange(kind, text, tuple(lines), None, error, sent_at, now, automatic))
            raise
        now = self.clock.now()
        exchange = Exchange(kind, text, reply.lines, reply.value, None, sent_at, now, automatic)
        self._notify(exchange)
        return exchange

    def _resync(self) -> None:
        """Discard everything up to the answer to a uniquely named probe.

        Raises BoardRebootedError, once in step again, if what was discarded shows that
        the board restarted: every setting, and the odometers, are back at power-up.
        """
        token = f"sync_{secrets.token_hex(4)}"
        answer = f"Unknown name: {token}"
        sent_at = self.clock.now()
        deadline = sent_at + self.timeout
        discarded: list[str] = []
        self._write(f"get {token}\r".encode("ascii"))
        while True:
            try:
                lines = self._read_until_prompt(deadline)
            except LinkTimeout as error:
                now = self.clock.now()
                self._notify(Exchange("resync", token, tuple(discarded), None, error, sent_at, now))
                raise LinkTimeout(f"no answer from the board on {self.port.port}") from None
            if answer in lines:
                discarded += [line for line in lines if line != answer]
                break
            discarded += [*lines, "OK >"]
        self._needs_resync = False
        rebooted = [line for line in discarded if is_banner(line) or line == CALIBRATION_LINE]
        restarted = (
            BoardRebootedError(f"the board restarted: {rebooted[-1]!r}") if rebooted else None
        )
        self._notify(
            Exchange("resync", token, tuple(discarded), None, restarted, sent_at, self.clock.now())
        )
        banners = [line for line in rebooted if is_banner(line)]
        if banners:
            self.version = banner_version(banners[-1])
        if restarted is not None:
            raise restarted

    def _unexpected_input(self) -> bool:
        """Bytes that arrived between exchanges: a sign that the line is out of step."""
        try:
            return bool(self._buffer) or self.port.in_waiting > 0
        except (OSError, serial.SerialException) as error:
            raise LinkDisconnected(f"lost the port {self.port.port}: {error}") from None

    def _write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (OSError, serial.SerialException) as error:
            raise LinkDisconnected(f"lost the port {self.port.port}: {error}") from None

    def _read_until_prompt(self, deadline: float) -> list[str]:
        """Reply lines up to the next prompt, which is consumed but not returned."""
        lines: list[str] = []
        while True:
            while True:
                end = self._buffer.find(b"\n")
                if end < 0:
                    break
                line = self._buffer[:end].decode("ascii", "replace").strip()
                del self._buffer[: end + 1]
                if is_prompt(line):
                    return lines
                if line:
                    lines.append(line)
            if len(self._buffer) > _MAX_LINE_BYTES:
                self._buffer.clear()
            if self.clock.now() >= deadline:
                raise LinkTimeout(f"the board did not answer within {self.timeout:g} s")
            try:
                self._buffer += self.port.read(max(1, self.port.in_waiting))
            except (OSError, serial.SerialException) as error:
                raise LinkDisconnected(f"lost the port {self.port.port}: {error}") from None
