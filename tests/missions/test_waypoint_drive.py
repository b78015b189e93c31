"""The thesis's way of moving, on the simulator with a virtual clock: stop, turn, drive."""

from __future__ import annotations

import math

from giraff_console.link import BoardLink, Exchange
from giraff_console.missions.waypoint_drive import WaypointDrive
from giraff_console.protocol.kinematics import TURN_FACTOR_DEG_PER_M
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.loop_events import ExchangeTap
from giraff_console.robot.mission import MissionEnd, Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.robot.safety import REACH_M
from giraff_console.robot.teleop import Teleop
from giraff_console.sim.drive import TruePose

TICK = 0.05
# Facing north at the origin; east 2 m, then north 1.5 m, ending facing north.
START = Pose(0.0, 0.0, math.pi / 2)
L_PATH = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.5)]


class Run:
    """A control loop on a simulated board, the robot placed at START, stepped at 20 Hz."""

    def __init__(self) -> None:
        self.link = BoardLink.open("giraff-sim://?clock=virtual")
        self.clock, self.board = self.link.port.clock, self.link.port.board
        self.control = ControlLoop(lambda: self.link, teleop=Teleop(),
                                   deadman=Deadman(self.clock), clock=self.clock)  # fmt: skip
        self.control.odometry.reset(START)
        self.board.place(TruePose(START.x, START.y, START.heading))
        self.control.tick()
        self.ends: list[MissionEnd] = []
        # Every target sent, as metres of reach (wheel metres when turning on the spot).
        self.reaches: list[float] = []
        self.poses: dict[float, TruePose] = {}
        self._style = 1.0
        self.control.subscribe(ExchangeTap(self._watch))

    def _watch(self, exchange: Exchange) -> None:
        if exchange.kind != "set" or exchange.error is not None:
            return
        _, name, text = exchange.command.split()
        if name == "r":
            self._style = float(text)
        elif name == "p":
            turning = self._style <= 0
            self.reaches.append(abs(float(text)) / (TURN_FACTOR_DEG_PER_M if turning else 1.0))

    def mission(self, points=L_PATH, goal_heading: float | None = math.pi / 2) -> WaypointDrive:
        return WaypointDrive(points, lambda: self.control.odometry.pose, goal_heading=goal_heading)

    def start(self, mission: WaypointDrive) -> None:
        self.control.run_mission(mission, self.ends.append)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / TICK)):
            if self.ends:
                return
            self.control.tick()
            self.poses[self.clock.now()] = self.board.true_pose
            self.clock.advance(TICK)


def test_it_reaches_the_end_of_an_l_shaped_path_stopping_at_the_corner():
    run = Run()
    mission = run.mission()
    run.start(mission)
    run.run(60.0)
    assert [end.outcome for end in run.ends] == [Outcome.DONE]
    truth = run.board.true_pose
    assert math.dist((truth.x, truth.y), L_PATH[-1]) <= 0.01
    assert abs(math.degrees(truth.heading - math.pi / 2)) <= 1.0
    (stop,) = mission.stops
    corner = run.poses[stop]
    assert math.dist((corner.x, corner.y), L_PATH[1]) <= 0.01


def test_it_never_sends_a_target_beyond_the_reach():
    run = Run()
    run.start(run.mission())
    run.run(60.0)
    assert [end.outcome for end in run.ends] == [Outcome.DONE]
    assert max(run.reaches) <= REACH_M
    # The legs and the turns of 90 degrees (0.39 wheel metres) are longer than that, so
    # the targets were renewed as the robot went.
    assert run.reaches.count(REACH_M) > 20


def test_waypoints_where_the_path_does_not_turn_are_driven_through():
    points = [(0.0, 0.0), (1.0, 0.0), (1.5, 0.0), (2.0, 0.0), (2.0, 1.0)]
    mission = WaypointDrive(points, lambda: Pose())
    assert mission.waypoints == [(2.0, 0.0), (2.0, 1.0)]


def test_a_paused_drive_carries_on_to_the_end_when_resumed():
    run = Run()
    mission = run.mission()
    run.start(mission)
    run.run(4.0)  # on the first leg
    run.control.pause_mission(True)
    run.run(3.0)
    run.control.pause_mission(False)
    run.run(60.0)
    assert [end.outcome for end in run.ends] == [Outcome.DONE]
    truth = run.board.true_pose
    assert math.dist((truth.x, truth.y), L_PATH[-1]) <= 0.01
    assert len(mission.stops) == 1
