"""An independent driver on the later firmware: it drives as the ROS 2 driver does and
integrates `imdl`/`imdr` as that driver does, with none of the console's code between
it and the wire (wire-facts "Later firmware"). Its pose must agree with the simulator's
true pose over a 10 m run: the simulator reports what such a driver expects."""

from __future__ import annotations

import math
import struct

import pytest
import serial

TICK = 0.05
WHEEL_BASE = 0.499


class RosStyleDriver:
    """Plain ASCII on a pyserial port: commands ended by CR, replies read to `OK >`."""

    def __init__(self, firmware: str) -> None:
        self.port = serial.serial_for_url(f"giraff-sim://?clock=virtual&firmware={firmware}",
                                          timeout=1.0)  # fmt: skip
        self.clock = self.port.clock
        self.x = self.y = self.heading = self.distance = 0.0
        self.read_lines()  # the greeting

    def read_lines(self) -> list[str]:
        lines = []
        for _ in range(20):
            line = self.port.readline().decode("ascii").strip()
            assert line, "no answer from the board"
            if line == "OK >":
                return lines
            lines.append(line)
        raise AssertionError(f"no prompt after {lines}")

    def send(self, text: str) -> list[str]:
        self.port.write(text.encode("ascii") + b"\r")
        lines = self.read_lines()
        assert not any("rror" in line or "Unknown" in line for line in lines), (text, lines)
        return lines

    def bulk(self) -> dict[str, float]:
        (line,) = self.send("get bulk_data")
        fields = {}
        for item in filter(None, line.split(",")):
            name, value = item.split(":")
            kind, digits = value.split("*")
            fields[name] = struct.unpack("<f" if kind == "F" else "<i", bytes.fromhex(digits))[0]
        return fields

    def integrate(self) -> dict[str, float]:
        """The ROS 2 driver's odometry: centre += (imdl + imdr) / 2, heading +=
        (imdr - imdl) / b, at the midpoint heading."""
        fields = self.bulk()
        left, right = fields["imdl"], fields["imdr"]
        turn = (right - left) / WHEEL_BASE
        mid = self.heading + turn / 2
        self.x += (left + right) / 2 * math.cos(mid)
        self.y += (left + right) / 2 * math.sin(mid)
        self.heading += turn
        self.distance += abs(left + right) / 2
        return fields

    def twist(self, speed: float, degrees_per_s: float, seconds: float) -> None:
        """Drive at `speed` turning at `degrees_per_s` (mode 2), renewing the move every
        tick as the driver does, and reading the odometry every tick."""
        self.send(f"set v {speed}")
        self.send(f"set vg {degrees_per_s}")
        for _ in range(round(seconds / TICK)):
            self.send("set p 1")
            self.clock.advance(TICK)
            self.integrate()

    def stop(self) -> None:
        """As both drivers stop the robot; then read until it stands still."""
        for text in ("set a 0", "set v 0", "set p 0"):
            self.send(text)
        for _ in range(200):
            self.clock.advance(TICK)
            if not int(self.integrate()["mode"]) & 128:
                return
        raise AssertionError("the robot did not stop")


@pytest.mark.parametrize("firmware", ["later", "giraff-x"])
def test_a_driver_integrating_imdl_imdr_agrees_with_the_true_pose_over_ten_metres(firmware):
    driver = RosStyleDriver(firmware)
    driver.send("set mode 2")
    driver.send("set a 0.5")
    driver.twist(0.4, 0.0, 5.0)
    driver.twist(0.3, 20.0, 6.0)
    driver.twist(0.4, -15.0, 7.0)
    driver.twist(0.4, 0.0, 9.0)
    driver.stop()
    truth = driver.port.board.true_pose
    assert driver.distance >= 10.0
    assert math.hypot(truth.x, truth.y) > 6.0 and abs(truth.heading) > math.radians(10)
    assert math.hypot(driver.x - truth.x, driver.y - truth.y) <= 0.01
    assert abs(math.degrees(math.remainder(driver.heading - truth.heading, math.tau))) <= 0.5
