"""Dead reckoning against the simulator's ground truth, polled through the link at 20 Hz."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from giraff_console.link import BoardLink
from giraff_console.protocol import ProtocolError
from giraff_console.robot import Odometry, Pose

POLL_S = 0.05  # 20 Hz, the console's control rate


class Drive:
    """A link to a simulated board on a virtual clock, with odometry on every poll."""

    def __init__(self) -> None:
        self.link = BoardLink.open("giraff-sim://?clock=virtual")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.odometry = Odometry()
        self.odometry.update(self.link.bulk())

    def poll(self) -> None:
        self.clock.advance(POLL_S)
        self.odometry.update(self.link.bulk())

    def move(self, **params: float) -> None:
        for name, value in params.items():
            self.link.set(name, value)
        self.poll()
        while self.link.bulk().moving:
            self.poll()

    def error(self) -> tuple[float, float]:
        """Position error (m) and heading error (degrees) of the estimate."""
        truth, estimate = self.board.true_pose, self.odometry.pose
        distance = math.hypot(truth.x - estimate.x, truth.y - estimate.y)
        heading = math.degrees(math.remainder(truth.heading - estimate.heading, math.tau))
        return distance, abs(heading)


def test_ten_metres_with_three_curves_and_a_rotation_stay_within_1cm_and_half_a_degree():
    drive = Drive()
    drive.link.set("a", 0.5)
    drive.link.set("v", 0.4)
    drive.move(r=1, p=2.0)
    drive.move(r=1000, vg=0.3, vgr=1.0, cdp=1.0, p=1.5)
    drive.move(r=1, cdp=0, p=1.5)
    drive.move(r=1000, vg=-0.4, vgr=-1.0, cdp=1.2, p=2.0)
    drive.move(r=0, p=120)
    drive.move(r=1, cdp=0, p=1.0)
    drive.move(r=1000, vg=0.25, vgr=0.8, cdp=0.8, p=2.0)
    state = drive.link.bulk()
    assert (state.imdl + state.imdr) / 2 == pytest.approx(10.0, abs=1e-4)
    truth = drive.board.true_pose
    assert abs(math.degrees(truth.heading)) > 45  # the run really turned
    distance, heading = drive.error()
    assert distance <= 0.01
    assert heading <= 0.5


def test_preempting_every_tick_loses_no_distance():
    # Teleop renews its target every tick; relative counters restart each time.
    drive = Drive()
    drive.link.set("a", 0.5)
    drive.link.set("v", 0.4)
    drive.link.set("r", 1000)
    drive.link.set("vgr", 1.0)
    for tick in range(120):
        drive.link.set("vg", 0.2 if tick < 60 else 0.0)
        drive.link.set("cdp", 0.3)
        drive.link.set("p", 0.3)
        drive.poll()
    drive.move(p=0.1)
    distance, heading = drive.error()
    assert drive.board.true_pose.x > 1.0
    assert distance <= 0.01
    assert heading <= 0.5


def test_rotating_clockwise_turns_the_heading_negative():
    drive = Drive()
    drive.move(r=0, a=0.5, v=0.2, p=90)
    assert drive.odometry.pose.heading == pytest.approx(-math.pi / 2, abs=1e-4)
    assert drive.odometry.pose.heading_deg == pytest.approx(270.0, abs=1e-3)
    assert (drive.odometry.pose.x, drive.odometry.pose.y) == pytest.approx((0, 0), abs=1e-9)


def test_straight_backwards():
    drive = Drive()
    drive.move(r=1, a=0.5, v=0.4, p=-1.5)
    assert drive.odometry.pose.x == pytest.approx(-1.5, abs=1e-6)
    assert drive.odometry.pose.heading == 0.0


def test_reset_starts_again_from_a_given_pose():
    drive = Drive()
    drive.move(r=1, a=0.5, v=0.4, p=1)
    drive.odometry.reset(Pose(5.0, 5.0, math.pi / 2))
    drive.odometry.update(drive.link.bulk())
    drive.move(p=1)
    assert (drive.odometry.pose.x, drive.odometry.pose.y) == pytest.approx((5.0, 6.0), abs=1e-6)


def test_a_board_without_wheel_distances_is_refused_clearly():
    drive = Drive()
    state = replace(drive.link.bulk(), imdl=None, imdr=None)
    with pytest.raises(ProtocolError, match="wheel distances"):
        Odometry().update(state)
