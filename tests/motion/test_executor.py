"""The path executor (motion/executor.py) on its own: what it sends the board."""

from __future__ import annotations

import pytest

from giraff_console.link.motor_state import MotorState
from giraff_console.motion.executor import MAX_GEAR, Executor
from giraff_console.motion.path import Drive, Segment, gear_of
from giraff_console.motion.speed_profile import MotionLimits
from giraff_console.robot.odometry import Pose

TICK = 0.05


def state(travelled: float, speed: float, now: float) -> MotorState:
    return MotorState(cang=0.0, cdis=travelled, gvr=speed, speed=speed, cvg=0.0, tilt=None,
                      imdl=travelled, imdr=travelled, mode=0, received_at=now)  # fmt: skip


def sent_speeds(executor: Executor, until: float, brake_at: float) -> list[float]:
    """Drive the executor along a straight line as though the robot kept to every speed
    it asked for, braking at `brake_at`; every `set v` it sent."""
    speeds, travelled, speed, now = [], 0.0, 0.0, 0.0
    while now < until and not executor.finished:
        if brake_at <= now < brake_at + TICK / 2:
            executor.brake(now)
        for command in executor.step(now, state(travelled, speed, now), Pose(travelled, 0, 0)):
            if command.kind == "set" and command.name == "v":
                speed = float(command.value)  # type: ignore[arg-type]
                speeds.append(speed)
        travelled += speed * TICK
        now += TICK
    return speeds


def test_a_brake_begun_while_speeding_up_to_the_top_speed_never_asks_past_it() -> None:
    limits = MotionLimits()
    drive = Drive((Segment(Pose(0, 0, 0), 8.0),))
    # Brake at every tick of the climb to the top speed in turn: each brake begins with
    # the robot still speeding up, and its curve goes on up for a moment.
    highest = 0.0
    for tick in range(10, 60, 4):
        speeds = sent_speeds(Executor([drive], limits, TICK), 12.0, tick * TICK)
        assert speeds, "the executor sent no speed"
        highest = max(highest, *speeds)
    assert highest <= limits.v_max
    assert highest > 0.9 * limits.v_max  # it did get up to speed


def first_gear(casters: float) -> float:
    """The gear ratio the executor first asks for on a straight drive from rest."""
    executor = Executor([Drive((Segment(Pose(0, 0, 0), 2.0),))], MotionLimits(), TICK)
    for now in (0.0, TICK, 2 * TICK):
        for command in executor.step(now, state(0.0, 0.0, now), Pose(0, 0, 0), casters):
            if command.kind == "set" and command.name == "vg":
                return float(command.value)  # type: ignore[arg-type]
    return 0.0


def test_a_drive_steers_against_the_turn_the_casters_are_expected_to_make() -> None:
    # Casters turning the robot left at 1 rad a metre: steer right by as much, which is
    # a positive gear ratio (vg = -k * 0.2495, path.py).
    assert first_gear(0.0) == 0.0
    assert first_gear(1.0) == pytest.approx(gear_of(-1.0), abs=1e-3)
    assert first_gear(-1.0) == pytest.approx(gear_of(1.0), abs=1e-3)
    # Never past the board's gear ratio limit, whatever the casters.
    assert first_gear(10.0) == pytest.approx(MAX_GEAR)


def test_a_robot_left_behind_its_profile_creeps_the_rest_within_the_jerk_limit() -> None:
    # The wheels make 90 % of every speed asked for: at the profile's end the robot is
    # short of the end, and creeps the rest, as a move of its own from rest.
    limits = MotionLimits()
    executor = Executor([Drive((Segment(Pose(0, 0, 0), 1.0),))], limits, TICK)
    travelled, speed, now = 0.0, 0.0, 0.0
    while now < 30.0 and not executor.finished:
        for command in executor.step(now, state(travelled, speed, now), Pose(travelled, 0, 0)):
            if command.kind == "set" and command.name == "v":
                speed = 0.9 * float(command.value)  # type: ignore[arg-type]
        travelled = min(1.0, travelled + speed * TICK)
        speed = speed if travelled < 1.0 else 0.0
        now += TICK
    assert executor.finished
    assert travelled == pytest.approx(1.0, abs=0.01)
    assert executor.trace.max_jerk() <= limits.j_max
    assert len(executor.trace.starts) >= 2  # the profile, then at least one creep


@pytest.mark.parametrize(("share", "length"), [(0.9, 1.0), (0.95, 6.0), (0.97, 3.0)])
def test_the_creep_begins_where_the_profile_ends_and_keeps_the_jerk_limit(
    share: float, length: float
) -> None:
    # A board that makes a little less than every speed asked for: the profile's own
    # clock, pulled by where the robot is, runs behind the wall clock, and the creep
    # must not begin while the profile's tail still moves (a kink of 3.9 m/s^3). The
    # jerk is taken over every tick, the creep's start included: it begins from rest.
    limits = MotionLimits()
    executor = Executor([Drive((Segment(Pose(0, 0, 0), length),))], limits, TICK)
    travelled, speed, now = 0.0, 0.0, 0.0
    while now < 60.0 and not executor.finished:
        for command in executor.step(now, state(travelled, speed, now), Pose(travelled, 0, 0)):
            if command.kind == "set" and command.name == "v":
                speed = share * float(command.value)  # type: ignore[arg-type]
        travelled = min(length, travelled + speed * TICK)
        speed = speed if travelled < length else 0.0
        now += TICK
    assert executor.finished
    assert travelled == pytest.approx(length, abs=0.01)
    executor.trace.starts[1:] = []  # every tick counts after the first
    assert executor.trace.max_jerk() <= limits.j_max
