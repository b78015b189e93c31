"""Two raw clients that talk to a Giraff board as the deployed drivers do.

They are modelled only on wire-facts' description of the two open-source drivers used on
deployed Giraffs ("Later firmware, as real drivers use it", "What the deployed drivers
do"), never on their code, and use none of the console's: they are the programs a
simulator and the virtual port must serve (issue 27).

- `Ros2LikeClient`: `mode 2`, a velocity loop at 40 Hz that renews `p = +-1` while
  driving and sends `set v 0` / `set vg 0` / `set p 0` every loop while idle, re-sends a
  command whose reply has not begun within 100 ms, reads the battery from `W:F#`, and
  integrates `imdl`/`imdr` as increments.
- `Ros1LikeClient`: starts with `set enc0 0`, `set enc1 0`, `set mode 0`, `set v 0`,
  `set a 0.2`, `set vgr 20` and waits for `tilt_homing_state` = 3; stops with
  `set a 0`, `set v 0`, `set p 0`, `set r 50`, `set vgr 0`; drives in mode 0, with `twm`
  on Giraff-X; polls `bulk_data`, `enc0`, `enc1`, `h` and `charger_data` every loop, and
  integrates the 16-bit encoders.

Each is given a `RawPort` (a file descriptor), so that the same client can be pointed at
the simulator's pty or at the daemon's virtual port. Every read has a deadline. The
wheel base is a setting (wire-facts "Geometry": 0.467 m in one driver, 0.499 m in the
thesis): give the robot's own.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from tests.drivers.wire import (
    COMMAND_END,
    SINGLE_VALUE_CHARS,
    RawPort,
    ReplyTimeout,
    charger_watt_seconds,
    decode_list,
    decode_value,
    is_error,
    reply_lines,
)

# One driver's battery constant: the level is |(c - W) / c| (wire-facts "Battery").
BATTERY_C = -327_360.0
# Encoders: counts per metre, and where the 16-bit counters wrap (wire-facts "Wheel encoders").
ENCODER_COUNTS_PER_M = 2002.0594
ENCODER_MODULUS = 65536
# The board's gear ratio for a curvature: kappa = vg / 0.2495, positive to the right
# (wire-facts "Quirks"; the firmware's geometry, whatever the robot's).
BOARD_TURN_RADIUS_M = 0.2495
# `mode` bit 128: moving (wire-facts "Quirks").
MOVING = 128


@dataclass
class Odometry:
    """A planar pose from wheel travel: centre += (left + right) / 2, heading +=
    (right - left) / b (wire-facts "imdl and imdr are increments"), the position moved
    at the step's middle heading."""

    wheel_base: float
    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0
    distance: float = 0.0  # travelled either way
    travelled: float = 0.0  # forwards less backwards

    def add(self, left: float, right: float) -> None:
        turn = (right - left) / self.wheel_base
        centre = (left + right) / 2
        middle = self.heading + turn / 2
        self.x += centre * math.cos(middle)
        self.y += centre * math.sin(middle)
        self.heading += turn
        self.distance += abs(centre)
        self.travelled += centre


@dataclass
class Traffic:
    """What a client saw on the wire: for tests, and for the lead's figures."""

    exchanges: int = 0
    resends: int = 0
    errors: list[tuple[str, str]] = field(default_factory=list)
    # Seconds from writing a command to its prompt.
    latencies: list[float] = field(default_factory=list)
    # Seconds each control loop took, start to start.
    loops: list[float] = field(default_factory=list)


class DriverClient:
    """What both drivers share: commands ended by CR, replies read to `OK >`, a `set`
    reply never read (any prompt counts as done), a `get` whose reply is not the usual 18
    characters sent again (wire-facts "What the deployed drivers do", Replies)."""

    # Tries of a `get` whose reply is malformed, before the client gives up: re-sending
    # for ever is a known failure (wire-facts "Known failures").
    GET_TRIES = 5

    def __init__(self, port: RawPort, wheel_base: float, reply_timeout: float = 1.0) -> None:
        self.port = port
        self.reply_timeout = reply_timeout
        self.odometry = Odometry(wheel_base)
        self.traffic = Traffic()
        self.version: str | None = None
        self.mode = 0
        self.battery_level: float | None = None

    # -- the wire -------------------------------------------------------------------------

    def greet(self, timeout: float = 3.0) -> str | None:
        """Read the greeting to its `OK >` and keep the `# Giraf` line's version; a port
        that does not greet is asked with an empty line, which any board answers with
        the prompt (wire-facts "Serial line")."""
        try:
            lines = reply_lines(self.port.read_to_prompt(timeout))
        except ReplyTimeout:
            lines = self._send_and_read("")
        for line in lines:
            if line.startswith("# Giraf"):
                self.version = line[len("# Giraf") :].strip()
        return self.version

    def _write(self, command: str) -> None:
        self.port.write(command.encode("ascii") + COMMAND_END)

    def _send_and_read(self, command: str) -> list[str]:
        started = time.monotonic()
        self._write(command)
        reply = self.port.read_to_prompt(self.reply_timeout)
        self.traffic.latencies.append(time.monotonic() - started)
        return reply_lines(reply)

    def exchange(self, command: str) -> list[str]:
        """Send one command and read its reply to the prompt; error lines are noted."""
        lines = self._send_and_read(command)
        self.traffic.exchanges += 1
        self.traffic.errors += [(command, line) for line in lines if is_error(line)]
        return lines

    def set(self, name: str, value: float | str) -> None:
        self.exchange(f"set {name} {value}")

    def get(self, name: str) -> float:
        """One value; a reply that is not the usual 18 characters is asked again."""
        for _ in range(self.GET_TRIES):
            lines = self.exchange(f"get {name}")
            if len(lines) == 1 and len(lines[0]) + len("\r\nOK >\r\n") == SINGLE_VALUE_CHARS:
                try:
                    return decode_value(lines[0])
                except ValueError:
                    continue
        raise ReplyTimeout(f"no well-formed answer to get {name} in {self.GET_TRIES} tries")

    def bulk(self) -> dict[str, float]:
        """`get bulk_data`; a reply that is not a list is asked again."""
        for _ in range(self.GET_TRIES):
            lines = self.exchange("get bulk_data")
            if len(lines) == 1 and "mode:" in lines[0]:
                try:
                    fields = decode_list(lines[0])
                except ValueError:
                    continue
                self.mode = int(fields["mode"])
                return fields
        raise ReplyTimeout(f"no bulk list in {self.GET_TRIES} tries")

    def read_battery(self, timeout: float = 5.0) -> float:
        """Read `charger_data` until `W` comes as a float, `W:F#` (one parameter per read,
        in turn), as one driver does (wire-facts "What the deployed drivers do"); the
        level is |(c - W) / c|. ReplyTimeout if it never comes within `timeout`."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.exchange("get charger_data"):
                drawn = charger_watt_seconds(line)
                if drawn is not None:
                    self.battery_level = abs((BATTERY_C - drawn) / BATTERY_C)
                    return self.battery_level
        raise ReplyTimeout(f"no W:F# from charger_data within {timeout} s")

    @property
    def moving(self) -> bool:
        return bool(self.mode & MOVING)


def _pace(period: float, started: float) -> float:
    """Sleep to the next loop start; returns it."""
    next_start = started + period
    delay = next_start - time.monotonic()
    if delay > 0:
        time.sleep(delay)
    return max(next_start, time.monotonic())


class Ros2LikeClient(DriverClient):
    """The ROS 2 driver's way: `mode 2`, velocities renewed at 40 Hz, `imdl`/`imdr`."""

    RATE_HZ = 40.0
    # A command whose reply has not begun within this long is sent again (wire-facts
    # "Pacing"): a late reply is then read as the next command's, as the driver does.
    RESEND_AFTER_S = 0.1
    RESEND_TRIES = 3
    ACCEL = 0.4  # within the drivers' 0.2 to 0.6 (wire-facts "Accelerations")

    def start(self) -> None:
        """Greet, `set mode 2` and an acceleration; never `r` (wire-facts "Start-up")."""
        self.greet()
        self.set("mode", 2)
        self.set("a", self.ACCEL)
        self.bulk()  # the increments so far are not this client's travel

    def _send_and_read(self, command: str) -> list[str]:
        started = time.monotonic()
        self._write(command)
        tries = 1
        while not self.port.reply_begun(self.RESEND_AFTER_S) and tries < self.RESEND_TRIES:
            self._write(command)
            self.traffic.resends += 1
            tries += 1
        reply = self.port.read_to_prompt(self.reply_timeout)
        self.traffic.latencies.append(time.monotonic() - started)
        return reply_lines(reply)

    def tick(self, speed: float, degrees_per_s: float) -> dict[str, float]:
        """One loop: the command (or the idle stop idiom), then `bulk_data` into the
        odometry. `speed` in m/s, forwards positive; `degrees_per_s` counter-clockwise
        positive, sent as `vg` unchanged (wire-facts "Sign in mode 2")."""
        if speed == 0 and degrees_per_s == 0:
            # Idle: the stop idiom on every loop (wire-facts "Idle").
            for name in ("v", "vg", "p"):
                self.set(name, 0)
        else:
            self.set("v", f"{abs(speed):.4f}")
            self.set("vg", f"{degrees_per_s:.4f}")
            self.set("p", -1 if speed < 0 else 1)  # renewed while driving
        fields = self.bulk()
        self.odometry.add(fields["imdl"], fields["imdr"])
        return fields

    def run(self, speed: float, degrees_per_s: float, until: Callable[[], bool],
            timeout: float) -> None:  # fmt: skip
        """Loop at 40 Hz sending (speed, rate) until `until()`; TimeoutError after `timeout`."""
        period = 1.0 / self.RATE_HZ
        deadline = time.monotonic() + timeout
        started = time.monotonic()
        while not until():
            if time.monotonic() > deadline:
                raise TimeoutError(f"not done within {timeout} s")
            self.tick(speed, degrees_per_s)
            next_start = _pace(period, started)
            self.traffic.loops.append(next_start - started)
            started = next_start

    def stop(self, timeout: float = 5.0) -> None:
        """Idle loops until the board reports the wheels at rest."""
        self.run(0.0, 0.0, lambda: not self.moving, timeout)

    def idle(self, loops: int) -> None:
        """`loops` idle loops: the stop idiom and `bulk_data`, at 40 Hz."""
        left = iter(range(loops))
        self.run(0.0, 0.0, lambda: next(left, None) is None, loops / self.RATE_HZ + 5.0)

    def drive(self, metres: float, speed: float = 0.3, timeout: float = 20.0) -> None:
        """Drive straight until the odometry has gone `metres`, less the braking distance
        at ACCEL, then stop."""
        start = self.odometry.distance
        brake = speed * speed / (2 * self.ACCEL)
        self.run(speed, 0.0, lambda: self.odometry.distance - start >= metres - brake, timeout)
        self.stop()

    def turn(self, degrees: float, rate: float = 30.0, timeout: float = 20.0) -> None:
        """Turn on the spot, counter-clockwise for positive `degrees`, at `rate` degrees a
        second (mode 2 with v = 0, wire-facts "Turning on the spot in mode 2"), stopping
        where the braking will end near `degrees`."""
        start = self.odometry.heading
        # The board's wheels turn at radians(rate) * 0.2495 m/s and brake at ACCEL.
        wheel_speed = math.radians(rate) * BOARD_TURN_RADIUS_M
        brake = math.degrees(wheel_speed**2 / (2 * self.ACCEL) / (self.odometry.wheel_base / 2))

        def turned() -> bool:
            return abs(math.degrees(self.odometry.heading - start)) >= abs(degrees) - brake

        self.run(0.0, math.copysign(rate, degrees), turned, timeout)
        self.stop()

    def curve(self, seconds: float, speed: float, degrees_per_s: float) -> None:
        """Drive `seconds` at `speed` turning at `degrees_per_s`, then stop."""
        until = time.monotonic() + seconds
        self.run(speed, degrees_per_s, lambda: time.monotonic() >= until, seconds + 5.0)
        self.stop()


class Ros1LikeClient(DriverClient):
    """The ROS 1 driver's way: mode 0 moves, `twm` curves on Giraff-X, 16-bit encoders."""

    RATE_HZ = 30.0
    ACCEL = 0.4  # within the drivers' 0.2 to 0.6 (wire-facts "Accelerations")

    def __init__(self, port: RawPort, wheel_base: float, reply_timeout: float = 1.0,
                 twm: bool = False) -> None:  # fmt: skip
        super().__init__(port, wheel_base, reply_timeout)
        self.twm = twm
        self._encoders: tuple[int, int] | None = None
        self.height: float | None = None

    def start(self, homing_timeout: float = 10.0) -> None:
        """The driver's start-up (wire-facts "Start-up"), then wait for the head's homing
        to read 3, which boards do by themselves at power-up (wire-facts "Tilt before
        homing")."""
        self.greet()
        for name, value in (("enc0", 0), ("enc1", 0), ("mode", 0), ("v", 0), ("a", 0.2),
                            ("vgr", 20)):  # fmt: skip
            self.set(name, value)
        deadline = time.monotonic() + homing_timeout
        while self.get("tilt_homing_state") != 3:
            if time.monotonic() > deadline:
                raise TimeoutError(f"the head did not home within {homing_timeout} s")
            time.sleep(0.05)
        self.poll()

    def stop_idiom(self) -> None:
        """`set a 0`, `set v 0`, `set p 0`, `set r 50`, `set vgr 0` (wire-facts "Stopping")."""
        for name, value in (("a", 0), ("v", 0), ("p", 0), ("r", 50), ("vgr", 0)):
            self.set(name, value)

    def poll(self) -> None:
        """One loop's reads: `bulk_data`, `enc0`, `enc1`, `h`, `charger_data` (wire-facts
        "Pacing"); the encoders go into the odometry, the shorter way round."""
        self.bulk()
        counts = (int(self.get("enc0")), int(self.get("enc1")))
        self.height = self.get("h")
        for line in self.exchange("get charger_data"):
            drawn = charger_watt_seconds(line)
            if drawn is not None:
                self.battery_level = abs((BATTERY_C - drawn) / BATTERY_C)
        if self._encoders is not None:
            left, right = (
                shorter_way(new - old) / ENCODER_COUNTS_PER_M
                for new, old in zip(counts, self._encoders, strict=True)
            )
            self.odometry.add(left, right)
        self._encoders = counts

    def idle(self, loops: int) -> None:
        """`loops` loops of polling, at the client's rate, as it does while idle."""
        period = 1.0 / self.RATE_HZ
        started = time.monotonic()
        for _ in range(loops):
            self.poll()
            next_start = _pace(period, started)
            self.traffic.loops.append(next_start - started)
            started = next_start

    def wait_until_still(self, timeout: float = 30.0) -> None:
        """Poll at the loop's rate until the board reports no move."""
        period = 1.0 / self.RATE_HZ
        deadline = time.monotonic() + timeout
        started = time.monotonic()
        self.poll()
        while self.moving:
            if time.monotonic() > deadline:
                raise TimeoutError(f"still moving after {timeout} s")
            next_start = _pace(period, started)
            self.traffic.loops.append(next_start - started)
            started = next_start
            self.poll()
        self.poll()  # the encoders at rest

    # How far ahead a move is re-targeted, at most (wire-facts "Known failures": the
    # drivers re-targeted up to 1 m or 90 degrees ahead), and how close to its end a
    # move counts as done.
    AHEAD_M = 1.0
    AHEAD_DEG = 90.0
    DONE_M = 0.002
    DONE_DEG = 0.2
    MOVE_TRIES = 20

    def drive(self, metres: float, speed: float = 0.3) -> None:
        """A straight move of `metres` in mode 0 (relative, r <= 50), to its end."""
        for name, value in (("mode", 0), ("r", 50), ("a", self.ACCEL), ("v", speed)):
            self.set(name, value)
        start = self.odometry.travelled
        self._move(lambda: metres - (self.odometry.travelled - start), self.AHEAD_M,
                   speed * speed / (2 * self.ACCEL), self.DONE_M,
                   lambda rest: [f"set p {rest:.4f}"])  # fmt: skip
        self.stop_idiom()

    def turn(self, degrees: float, speed: float = 0.15) -> None:
        """Turn on the spot, counter-clockwise for positive `degrees` (r = 0: p in degrees,
        positive clockwise, wire-facts "Quirks")."""
        for name, value in (("mode", 0), ("r", 0), ("a", self.ACCEL), ("v", speed)):
            self.set(name, value)
        start = self.odometry.heading
        # Braking from the wheels' speed, in degrees of the robot's turn.
        brake = math.degrees(speed * speed / (2 * self.ACCEL) / (self.odometry.wheel_base / 2))
        self._move(lambda: degrees - math.degrees(self.odometry.heading - start),
                   self.AHEAD_DEG, brake, self.DONE_DEG,
                   lambda rest: [f"set p {-rest:.4f}"])  # fmt: skip
        self.stop_idiom()

    def curve(self, metres: float, speed: float, degrees_per_m: float) -> None:
        """A curve of `metres` turning `degrees_per_m`, counter-clockwise positive: the
        gear ratio is -kappa * 0.2495 (positive to the right, wire-facts "Quirks"),
        ramped by the start-up's vgr, held to the end (cdp = what is left). With `twm` on
        Giraff-X, after the stop idiom left r = 50 (wire-facts "twm on Giraff-X");
        otherwise as separate sets with r > 50."""
        gear = -math.radians(degrees_per_m) * BOARD_TURN_RADIUS_M
        self.set("a", self.ACCEL)
        self.set("mode", 0)
        if not self.twm:
            for name, value in (("r", 100), ("vg", f"{gear:.4f}"), ("vgr", 20), ("v", speed)):
                self.set(name, value)

        def commands(rest: float) -> list[str]:
            if self.twm:
                return [f"set twm {gear:.4f} {rest:.4f} 20 {speed:.4f} {rest:.4f} 0"]
            return [f"set cdp {rest:.4f}", f"set p {rest:.4f}"]

        start = self.odometry.travelled
        self._move(lambda: metres - (self.odometry.travelled - start), self.AHEAD_M,
                   speed * speed / (2 * self.ACCEL), self.DONE_M, commands)  # fmt: skip
        self.stop_idiom()

    def _move(self, left: Callable[[], float], ahead: float, brake: float, done: float,
              commands: Callable[[float], list[str]]) -> None:  # fmt: skip
        """Re-target the move each loop, from where the robot is, at most `ahead` of it,
        while more than the braking distance `brake` is left (by the client's odometry);
        then send what is left and wait until still. Again if the robot stopped short
        (the virtual port keeps each target within the console's reach)."""
        period = 1.0 / self.RATE_HZ
        for _ in range(self.MOVE_TRIES):
            started = time.monotonic()
            while abs(left()) > brake + done:
                rest = left()
                for command in commands(math.copysign(min(abs(rest), ahead), rest)):
                    self.exchange(command)
                next_start = _pace(period, started)
                self.traffic.loops.append(next_start - started)
                started = next_start
                self.poll()
            if abs(left()) <= done:
                return
            for command in commands(left()):
                self.exchange(command)
            self.wait_until_still()
            if abs(left()) <= done:
                return
        raise TimeoutError(f"{left():.4f} still to go after {self.MOVE_TRIES} tries")


def shorter_way(step: int) -> int:
    """A counter's change between two reads, taking the shorter way round the wrap."""
    return (step + ENCODER_MODULUS // 2) % ENCODER_MODULUS - ENCODER_MODULUS // 2
