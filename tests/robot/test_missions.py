"""The control loop runs a mission within the limits and stops it whenever it must."""

from __future__ import annotations

import pytest
import serial

from giraff_console.link import LinkDisconnected, MotorState
from giraff_console.protocol.codec import Command
from giraff_console.protocol.errors import GiraffError
from giraff_console.protocol.mode import ModeBit
from giraff_console.recording.control_log import LogEntry, LogRead
from giraff_console.recording.playback import Playback
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.mission import DRIVING, Progress
from giraff_console.robot.safety import stop_robot
from giraff_console.robot.teleop import Teleop
from giraff_console.runtime.board import board_connector
from giraff_console.settings import Settings
from tests.listening import notes_into

TICK = 0.05


class Ahead:
    """A mission that drives on like held Up: a 0.24 m target renewed every 0.25 s."""

    name = "ahead"
    problem = None

    def __init__(self, command: Command | None = None, fail: bool = False) -> None:
        self.command = command or Command("set", "p", 0.24)
        self.fail = fail
        self.paused = False
        self.steps = 0
        self._next = 0.0

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        if self.fail:
            raise RuntimeError("a bug in the mission")
        if self.paused or now < self._next:
            return []
        self.steps += 1
        self._next = now + 0.25
        return [self.command]

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None:
        self.paused = True

    def resume(self, now: float) -> None:
        self.paused, self._next = False, now

    @property
    def finished(self) -> bool:
        return False

    @property
    def progress(self) -> Progress:
        return Progress("ahead", DRIVING)


class Loop:
    def __init__(self) -> None:
        self.port = serial.serial_for_url("giraff-sim://?clock=virtual")
        self.clock = self.port.clock
        self.board = self.port.board
        self.notes: list[str] = []
        # As the console connects: again, on the same board, after the loop let go of it.
        self.control = ControlLoop(board_connector(None, Settings(), self.port), teleop=Teleop(),
                                   deadman=Deadman(self.clock), clock=self.clock)  # fmt: skip
        self.control.subscribe(notes_into(self.notes))

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / TICK)):
            self.control.tick()
            self.clock.advance(TICK)

    def start(self, mission) -> None:
        self.run(0.1)
        self.control.run_mission(mission)
        self.run(1.5)

    def at_rest_after(self, seconds: float = 2.0) -> bool:
        """True if the robot comes to rest and then stays put."""
        self.run(seconds)
        x = self.board.true_pose.x
        self.run(1.0)
        return self.board.true_pose.x == x and not self.board.drive.mode_bits() & ModeBit.MOVING


@pytest.fixture
def loop() -> Loop:
    return Loop()


def test_a_mission_drives_while_it_runs(loop):
    loop.start(Ahead())
    assert loop.control.mission is not None
    assert loop.board.true_pose.x > 0.3
    assert "ahead started" in loop.notes


def test_the_operators_keys_take_over_at_once(loop):
    loop.start(Ahead())
    loop.control.press(Intent.LEFT)
    loop.run(0.1)
    assert loop.control.mission is None
    assert "ahead stopped: the operator took the keys" in loop.notes


def test_stopping_a_mission_stops_the_robot(loop):
    loop.start(Ahead())
    loop.control.stop_mission("stopped by the operator")
    assert loop.at_rest_after()
    assert loop.control.mission is None


def test_estop_ends_the_mission(loop):
    mission = Ahead()
    loop.start(mission)
    loop.board.set_estop(True)
    loop.run(0.2)
    assert loop.control.mission is None
    steps = mission.steps
    loop.board.set_estop(False)
    loop.run(1.0)
    assert mission.steps == steps  # nothing more was asked of it
    assert "ahead stopped by ESTOP" in loop.notes


def test_a_command_outside_the_limits_ends_the_mission_and_stops_the_robot(loop):
    loop.start(Ahead())
    loop.control.run_mission(Ahead(Command("set", "p", 0.5)))  # beyond the runaway limit
    loop.run(0.1)
    assert loop.control.mission is None
    assert any("refused" in note for note in loop.notes)
    assert loop.at_rest_after()


def test_pause_stops_the_robot_and_resume_drives_on(loop):
    loop.start(Ahead())
    loop.control.pause_mission(True)
    assert loop.at_rest_after()
    x = loop.board.true_pose.x
    loop.control.pause_mission(False)
    loop.run(1.0)
    assert loop.board.true_pose.x > x + 0.1


def test_a_lost_link_ends_the_mission(loop):
    loop.start(Ahead())
    loop.port.close()
    loop.control.tick()
    assert loop.control.mission is None
    assert "ahead stopped: the link to the board was lost" in loop.notes


def test_a_bug_in_a_mission_stops_the_robot_and_the_mission_stays_stopped(loop):
    mission = Ahead()
    loop.start(mission)
    mission.fail = True
    loop.run(0.1)
    assert loop.control.mission is None
    assert "ahead stopped: internal error" in loop.notes
    mission.fail = False
    assert loop.at_rest_after()


def test_during_a_playback_only_a_stop_reaches_the_robot(loop):
    loop.run(0.1)
    log = LogRead([LogEntry(t / 10, "G", "v", "0.40000") for t in range(40)], [])
    loop.control.play(Playback("test", log, loop.clock.now()))
    loop.run(0.2)
    results: list[object] = []
    loop.control.submit(lambda link: link.send(Command("set", "p", 0.2)), results.append)
    loop.control.submit(stop_robot, results.append, stop=True)
    loop.run(1.0)
    assert isinstance(results[0], GiraffError) and "playing back" in str(results[0])
    assert results[1] is True
    assert loop.board.true_pose.x == 0.0


def test_a_mission_never_starts_by_itself_when_a_lost_link_comes_back(loop):
    loop.run(0.1)
    loop.port.close()
    connect = loop.control.connect
    loop.control.connect = lambda: (_ for _ in ()).throw(LinkDisconnected("unplugged"))
    loop.run(0.2)
    loop.control.run_mission(Ahead())
    loop.run(1.0)
    assert loop.control.mission is None
    assert "ahead not started: no link to the board" in loop.notes
    loop.control.connect = connect
    loop.run(5.0)
    assert loop.board.true_pose.x == 0.0


def test_a_board_that_restarts_ends_the_mission(loop):
    loop.start(Ahead())
    loop.port.dtr = False  # a brown-out: the board loses power and greets again
    loop.port.dtr = True
    loop.run(0.3)
    assert loop.control.mission is None
    assert "ahead stopped: the board restarted" in loop.notes
    x = loop.board.true_pose.x
    loop.run(3.0)
    assert loop.board.true_pose.x == pytest.approx(x, abs=0.3)  # at most the last target
    assert loop.at_rest_after()


def test_a_playback_begun_while_driving_leaves_teleop_idle_for_the_next_mission(loop):
    loop.run(0.1)
    for _ in range(30):
        loop.control.press(Intent.FORWARD)
        loop.run(0.05)
    log = LogRead([LogEntry(t / 10, "G", "v", "0.40000") for t in range(10)], [])
    loop.control.play(Playback("test", log, loop.clock.now()))
    loop.run(3.0)
    assert loop.control.playback is None
    mission = Ahead()
    loop.control.run_mission(mission)
    loop.run(1.0)
    assert mission.steps > 0 and loop.control.mission is mission
