"""The limits every command meets: a move's acceleration must stop the robot within the
runaway limit from the fastest it may be going."""

from __future__ import annotations

import pytest

from giraff_console.protocol import Command, CommandError
from giraff_console.robot.command_guard import braking_accel, check_command
from giraff_console.robot.teleop import DriveLimits

LIMITS = DriveLimits()
BOARD = {"r": "1000", "mode": "0", "v": "0.4", "vg": "0", "a": "0.5"}


def test_without_the_speed_an_acceleration_must_stop_the_robot_from_top_speed():
    with pytest.raises(CommandError, match="a must be in"):
        check_command(Command("set", "a", 0.2), LIMITS, BOARD)
    check_command(Command("set", "a", LIMITS.min_accel), LIMITS, BOARD)


def test_knowing_the_speed_a_gentler_acceleration_is_allowed_at_low_speed():
    # At 0.1 m/s the robot stops within 0.3 m at 1/60 m/s^2.
    check_command(Command("set", "a", 0.02), LIMITS, BOARD, speed=0.1)
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.01), LIMITS, BOARD, speed=0.1)
    # And not at cruising speed.
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.2), LIMITS, BOARD, speed=0.4)


def test_a_move_is_checked_against_the_acceleration_the_board_holds():
    gentle = BOARD | {"a": "0.02"}
    check_command(Command("set", "p", 0.28), LIMITS, gentle, speed=0.1)
    with pytest.raises(CommandError):
        check_command(Command("set", "p", 0.28), LIMITS, gentle, speed=0.3)
    with pytest.raises(CommandError, match="p beyond"):
        check_command(Command("set", "p", 0.31), LIMITS, BOARD, speed=0.0)


def test_a_zero_acceleration_is_never_allowed():
    with pytest.raises(CommandError):
        check_command(Command("set", "a", 0.0), LIMITS, BOARD, speed=0.0)


def test_the_braking_acceleration_stops_the_robot_at_the_runaway():
    accel = braking_accel(0.4, 0.3)
    assert 0.4**2 / (2 * accel) == pytest.approx(0.3)
