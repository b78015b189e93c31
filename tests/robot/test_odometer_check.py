"""The first-motion check, against a hand-driven board on a virtual clock: wheels that
turn as driven, imdl/imdr as totals or increments, cdis restarting with every move."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from giraff_console.link import MotorState
from giraff_console.robot.odometer_check import OdometerCheck
from giraff_console.robot.odometry import Pose
from giraff_console.robot.wheel_odometers import COUNTS_PER_METRE, Reading

TICK_S = 0.05
SEND_DELAY_S = 0.006  # a poll's answer to the move going out, on a real line
BASE = 0.499


class HandBoard:
    """A board's counters for a robot driven at a given speed and gear ratio."""

    def __init__(self, increments: bool, wheels_forward: float = 3.0) -> None:
        self.increments = increments
        self.left = self.right = wheels_forward  # metres since power-up
        self.read_left = self.read_right = 0.0  # what the last read had seen
        self.cdis = 0.0
        self.now = 0.0
        self.pose = Pose()

    def run(self, seconds: float, speed: float, gear: float = 0.0) -> None:
        steps = 20
        for _ in range(steps):
            dt = seconds / steps
            left, right = speed * (1 + gear) * dt, speed * (1 - gear) * dt
            self.left += left
            self.right += right
            self.cdis += (left + right) / 2
            turn = (right - left) / BASE
            mid = self.pose.heading + turn / 2
            centre = (left + right) / 2
            x, y = self.pose.x + centre * math.cos(mid), self.pose.y + centre * math.sin(mid)
            self.pose = Pose(x, y, self.pose.heading + turn)
            self.now += dt

    def poll(self) -> MotorState:
        if self.increments:
            imdl, imdr = self.left - self.read_left, self.right - self.read_right
            self.read_left, self.read_right = self.left, self.right
        else:
            imdl, imdr = self.left, self.right
        enc0, enc1 = (round(w * COUNTS_PER_METRE) % 65_536 for w in (self.left, self.right))
        return MotorState(cang=0.0, cdis=self.cdis, gvr=0.0, speed=0.0, cvg=0.0, tilt=None,
                          imdl=imdl, imdr=imdr, mode=128, received_at=self.now, enc0=enc0,
                          enc1=enc1)  # fmt: skip

    def move(self) -> float:
        """A relative move goes out: cdis restarts (A.4.8)."""
        self.cdis = 0.0
        return self.now


def drive(check: OdometerCheck, board: HandBoard, ticks: int, gear: float = 0.0,
          path: bool = True, encoders: bool = True, delay: float = SEND_DELAY_S,
          answer_s: float = 0.0):  # fmt: skip
    """Teleop's pattern: poll, a move a few milliseconds later, every tick, accelerating
    to 0.4 m/s. With `answer_s`, each poll's answer arrives that long after the board
    took it, and the check is told when it was sent. Returns the outcome and the
    distance driven when it came."""
    speed = 0.0
    for _ in range(ticks):
        state = board.poll()
        if not encoders:
            state = replace(state, enc0=None, enc1=None)
        if answer_s:
            sent = state.received_at
            outcome = check.sample(replace(state, received_at=sent + answer_s), at=sent)
        else:
            outcome = check.sample(state)
        if outcome is not None:
            return outcome, board.left
        board.run(delay, speed, gear)
        check.move_sent(board.move(), counts=path)
        speed = min(0.4, speed + 0.5 * TICK_S)
        board.run(TICK_S - delay, speed, gear)
    return None, board.left


def test_totals_that_are_totals_are_trusted_within_the_first_half_metre():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=False)
    outcome, wheels = drive(check, board, 100)
    assert outcome is not None and not outcome.switched
    assert outcome.reading is Reading.TOTALS
    assert wheels - 3.0 < 0.5
    assert outcome.trusted and "agree with cdis" in outcome.message


def test_increments_read_as_totals_are_found_out_and_the_pose_is_put_right():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=True)
    outcome, wheels = drive(check, board, 100, gear=0.1)
    assert outcome is not None and outcome.switched
    assert outcome.reading is Reading.INCREMENTS
    assert wheels - 3.0 < 1.0  # within the first metre
    assert outcome.message.startswith(
        "odometry: the board's imdl/imdr behave as increments, not as totals as the "
        "settings say: over 0.3"
    )
    assert "they read 0.0" in outcome.message
    assert outcome.message.endswith("now reading imdl/imdr as increments")
    # The pose integrated the right way from the start, in a curve.
    assert outcome.odometry is not None
    pose = outcome.odometry.pose
    assert math.hypot(pose.x - board.pose.x, pose.y - board.pose.y) < 1e-3
    assert pose.heading == pytest.approx(board.pose.heading, abs=1e-3)
    assert board.pose.heading < -0.1  # it really curved


def test_totals_read_as_increments_are_found_out():
    check = OdometerCheck(Reading.INCREMENTS, Pose(), wheel_base=BASE, encoders=False,
                          source="its firmware suggests")  # fmt: skip
    outcome, _ = drive(check, HandBoard(increments=False), 100)
    assert outcome is not None and outcome.reading is Reading.TOTALS
    assert "not as increments as its firmware suggests" in outcome.message


def test_the_encoders_are_preferred_to_imdl_and_imdr_that_are_not_as_claimed():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=True)
    board = HandBoard(increments=True)
    outcome, _ = drive(check, board, 100)
    assert outcome is not None and outcome.reading is Reading.ENCODERS
    assert "behave as increments, not as totals" in outcome.message
    assert outcome.message.endswith("now reading the wheel encoders")
    assert outcome.odometry is not None
    assert outcome.odometry.pose.x == pytest.approx(board.pose.x, abs=1e-3)


def test_the_encoders_are_checked_too():
    check = OdometerCheck(Reading.ENCODERS, Pose(), wheel_base=BASE, encoders=True)
    outcome, _ = drive(check, HandBoard(increments=True), 100)
    assert outcome is not None and outcome.reading is Reading.ENCODERS
    assert not outcome.switched


def test_when_nothing_agrees_the_claimed_reading_stays_and_it_is_said():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=False)
    # A cdis that reads twice the wheels' travel: no reading agrees with it.
    poll = board.poll
    board.poll = lambda: replace(poll(), cdis=board.cdis * 2)  # type: ignore[method-assign]
    outcome, _ = drive(check, board, 100)
    assert outcome is not None and not outcome.switched and not outcome.agreed
    assert outcome.message.startswith("odometry: no wheel reading agrees with cdis")
    assert outcome.message.endswith("still reading totals, but the pose cannot be trusted")


def test_rotations_and_moves_it_cannot_measure_do_not_count():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=True)
    outcome, _ = drive(check, board, 200, path=False)
    assert outcome is None


def test_a_move_sent_late_in_the_interval_is_scaled_from_the_time_since_it():
    # Moves 20 ms after each poll: unscaled, cdis would miss 40 % of every interval.
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    outcome, _ = drive(check, HandBoard(increments=False), 100, delay=0.02)
    assert outcome is not None and not outcome.switched
    assert outcome.trusted and "agree with cdis" in outcome.message


def test_answers_that_take_their_time_on_the_wire_do_not_skew_cdis():
    # A 115200-baud line: bulk_data's answer arrives 14 ms after the board took it, and
    # the move goes out once it has. Timed by arrival, cdis would read 25 % low.
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    outcome, _ = drive(check, HandBoard(increments=False), 100, delay=0.016, answer_s=0.014)
    assert outcome is not None and outcome.trusted, outcome.message


def test_polls_without_a_move_between_them_difference_cdis():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=False)
    check.sample(board.poll())
    check.move_sent(board.move(), counts=True)
    outcome = None
    for _ in range(40):  # one long move, polled without renewals
        board.run(TICK_S, 0.3)
        outcome = outcome or check.sample(board.poll())
    assert outcome is not None and not outcome.switched


def test_a_restarted_board_starts_the_check_again():
    check = OdometerCheck(Reading.TOTALS, Pose(), wheel_base=BASE, encoders=False)
    board = HandBoard(increments=True)
    assert drive(check, board, 8)[0] is None
    check.restart(Pose(1.0, 0.0, 0.0))
    outcome, _ = drive(check, board, 100)
    assert outcome is not None and outcome.odometry is not None
    assert outcome.odometry.pose.x > 1.0
