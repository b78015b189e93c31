"""Odometry on each firmware profile of the simulator: the three readings over 10 m, the
control loop's pose, and settings that claim the wrong reading (issue 13)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from giraff_console.link import (
    BoardFeatures,
    BoardLink,
    Exchange,
    LinkDisconnected,
    MotorState,
    probe,
)
from giraff_console.missions.go_to import GoTo
from giraff_console.missions.navigation import Navigator
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol.codec import Command
from giraff_console.robot import control_loop
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.mission import DRIVING, MissionEnd, Outcome, Progress
from giraff_console.robot.odometry import Odometry
from giraff_console.robot.teleop import Teleop
from giraff_console.robot.wheel_odometers import Reading
from giraff_console.runtime.sim_site import SimulatedSite
from tests.listening import notes_into
from tests.missions.site import LIMITS, PLAN

TICK = 0.05
PROFILES = ("thesis", "later", "giraff-x")


def open_board(firmware: str, options: str = "") -> BoardLink:
    return BoardLink.open(f"giraff-sim://?clock=virtual&firmware={firmware}{options}")


class Drive:
    """A driver's view of a simulated board: the odometry gets every read of bulk_data
    (a read resets later boards' increments), with the encoders read after each."""

    def __init__(self, firmware: str, reading: Reading) -> None:
        self.link = open_board(firmware)
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.reading = reading
        self.odometry = Odometry(reading=reading)
        self.link.add_observer(self._watch)
        self.poll()

    def _watch(self, exchange: Exchange) -> None:
        if exchange.command == "get bulk_data" and self.reading is not Reading.ENCODERS:
            assert isinstance(exchange.value, dict)
            self.odometry.update(MotorState.from_bulk(exchange.value, exchange.answered_at))

    def poll(self) -> MotorState:
        state = self.link.bulk()
        if self.reading is Reading.ENCODERS:
            counts = [self.link.get(name) for name in ("enc0", "enc1")]
            assert all(isinstance(count, int) for count in counts)
            self.odometry.update(replace(state, enc0=counts[0], enc1=counts[1]))  # type: ignore[arg-type]
        return state

    def move(self, **params: float) -> None:
        for name, value in params.items():
            self.link.set(name, value)
        self.clock.advance(TICK)
        while self.poll().moving:
            self.clock.advance(TICK)


@pytest.mark.parametrize(("firmware", "reading"), [
    ("thesis", Reading.TOTALS),
    ("later", Reading.INCREMENTS),
    ("later", Reading.ENCODERS),
    ("giraff-x", Reading.INCREMENTS),
])  # fmt: skip
def test_ten_metres_with_curves_and_a_rotation_on_each_reading(firmware, reading):
    drive = Drive(firmware, reading)
    drive.link.set("a", 0.5)
    drive.link.set("v", 0.4)
    drive.move(r=1, p=2.0)
    drive.move(r=1000, vg=0.3, vgr=1.0, cdp=1.0, p=1.5)
    drive.move(r=1, cdp=0, p=1.5)
    drive.move(r=1000, vg=-0.4, vgr=-1.0, cdp=1.2, p=2.0)
    drive.move(r=0, p=120)
    drive.move(r=1, cdp=0, p=1.0)
    drive.move(r=1000, vg=0.25, vgr=0.8, cdp=0.8, p=2.0)
    truth, estimate = drive.board.true_pose, drive.odometry.pose
    assert abs(math.degrees(truth.heading)) > 45  # the run really turned
    assert math.hypot(truth.x - estimate.x, truth.y - estimate.y) <= 0.01
    assert abs(math.degrees(math.remainder(truth.heading - estimate.heading, math.tau))) <= 0.5


class Console:
    """A control loop on a simulated board, stepped by hand on the board's clock."""

    def __init__(self, firmware: str, odometers: str = "auto", options: str = "",
                 twm: str = "auto") -> None:  # fmt: skip
        """`options`: more of the simulator's URL, e.g. `&pace=1` for a 115200-baud line."""
        self.link = open_board(firmware, options)
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.reports: list[str] = []
        self.loop = ControlLoop(lambda: self.link, teleop=Teleop(), deadman=Deadman(self.clock),
                                clock=self.clock, odometers=odometers, twm=twm)  # fmt: skip
        self.loop.subscribe(notes_into(self.reports))

    def run(self, seconds: float) -> None:
        end = self.clock.now() + seconds
        while self.clock.now() < end - 1e-9:
            self.loop.tick()
            self.clock.advance(TICK)

    def hold(self, intent: Intent, seconds: float) -> None:
        """The key held, as a terminal repeats it, ticking at 20 Hz; then let go."""
        end = self.clock.now() + seconds
        while self.clock.now() < end - 1e-9:
            self.loop.press(intent)
            self.loop.tick()
            self.clock.advance(TICK)
        self.run(1.5)

    def error(self) -> tuple[float, float]:
        """Position (m) and heading (degrees) error of the loop's pose."""
        truth, pose = self.board.true_pose, self.loop.odometry.pose
        heading = math.degrees(math.remainder(truth.heading - pose.heading, math.tau))
        return math.hypot(truth.x - pose.x, truth.y - pose.y), abs(heading)


@pytest.mark.parametrize("firmware", PROFILES)
def test_the_loop_s_pose_follows_the_robot_straight_and_in_a_curve(firmware):
    console = Console(firmware)
    console.run(TICK)
    assert console.reports[0].startswith(f"connected to giraff-sim://?clock=virtual&firmware="
                                         f"{firmware}, board {console.link.version}: ")  # fmt: skip
    console.hold(Intent.FORWARD, 2.5)
    assert console.board.true_pose.x >= 1.0
    assert console.error()[0] <= 0.01
    console.hold(Intent.FORWARD_LEFT, 3.0)
    assert console.board.true_pose.heading > 0.5  # it really curved
    distance, heading = console.error()
    assert distance <= 0.01 and heading <= 0.5
    # Checked against cdis, found right, and nothing said about it.
    assert console.loop.feed.check is None
    assert not any(r.startswith("odometry") for r in console.reports), console.reports
    expected = Reading.TOTALS if firmware == "thesis" else Reading.INCREMENTS
    assert console.loop.odometry.reading is expected


@pytest.mark.parametrize(("firmware", "claimed", "message", "now"), [
    ("later", "totals",
     "odometry: the board's imdl/imdr behave as increments, not as totals as the settings say",
     Reading.ENCODERS),
    ("thesis", "increments",
     "odometry: the board's imdl/imdr behave as totals, not as increments as the settings say",
     Reading.TOTALS),
])  # fmt: skip
def test_settings_that_claim_the_wrong_reading_are_found_out_in_the_first_metre(
    firmware, claimed, message, now
):
    console = Console(firmware, odometers=claimed)
    console.run(TICK)
    while True:
        assert console.board.true_pose.x < 1.0, console.reports
        console.loop.press(Intent.FORWARD)
        console.loop.tick()  # polls, then drives
        if any(r.startswith(message) for r in console.reports):
            break
        console.clock.advance(TICK)
    assert console.loop.odometry.reading is now
    # Put right from the start of the check: as good as the poll just taken.
    assert console.error()[0] <= 0.002
    console.hold(Intent.FORWARD, 1.0)
    console.hold(Intent.FORWARD_RIGHT, 3.0)
    distance, heading = console.error()
    assert distance <= 0.01 and heading <= 0.5


# A 115200-baud line: bulk_data's answer spends about 14 ms on the wire, a set's 2 ms.
PACED = "&pace=1"


@pytest.mark.parametrize("firmware", PROFILES)
def test_on_a_115200_baud_line_the_right_reading_is_trusted_without_an_alarm(firmware):
    # A move every tick, as `go` and a route send them: cdis restarts between most polls.
    console = Console(firmware, options=PACED)
    console.run(TICK)
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(3.0)
    assert not ended, console.reports
    assert console.loop.feed.check is None  # decided...
    assert console.loop.feed.untrusted is None  # ...for the reading it claimed
    assert not any(r.startswith("odometry") for r in console.reports), console.reports
    console.loop.stop_mission()
    console.run(1.5)
    assert console.error()[0] <= 0.01


def test_on_a_115200_baud_line_totals_claimed_on_a_later_board_are_switched_in_the_first_metre():
    console = Console("later", odometers="totals", options=PACED)
    console.run(TICK)
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    found = "odometry: the board's imdl/imdr behave as increments, not as totals as the settings"
    give_up = console.clock.now() + 5.0  # the mission would have gone 1 m long before
    while not any(r.startswith(found) for r in console.reports):
        assert console.board.true_pose.x < 1.0, console.reports
        assert console.clock.now() < give_up, console.reports
        console.run(TICK)
    assert console.loop.odometry.reading is Reading.ENCODERS
    assert console.loop.feed.untrusted is None
    assert ended and ended[0].outcome is Outcome.LOST and "its pose was wrong" in ended[0].why
    console.hold(Intent.FORWARD_RIGHT, 3.0)
    distance, heading = console.error()
    assert distance <= 0.01 and heading <= 0.5


def test_without_encoders_the_other_interpretation_takes_over(monkeypatch):
    # A later board that has no encoders (or none the probe found): only imdl/imdr left.
    def without_encoders(link: BoardLink) -> BoardFeatures:
        return replace(probe(link), encoders=False)

    monkeypatch.setattr(control_loop, "probe", without_encoders)
    console = Console("later", odometers="totals")
    console.hold(Intent.FORWARD, 2.0)
    found = "odometry: the board's imdl/imdr behave as increments, not as totals as the settings"
    switched = "now reading imdl/imdr as increments"
    assert any(r.startswith(found) and r.endswith(switched) for r in console.reports)
    assert console.loop.odometry.reading is Reading.INCREMENTS
    assert console.error()[0] <= 0.01


class Straight:
    """A mission that renews a short straight target every tick, forever."""

    name = "straight"
    finished = False
    problem = None
    progress = Progress(name, DRIVING)

    def step(self, now: float, state: MotorState | None) -> list[Command]:
        return [Command("set", "p", 0.2)]

    def next_due(self) -> float | None:
        return None

    def pause(self, now: float) -> None: ...

    def resume(self, now: float) -> None: ...


def test_a_mission_driving_by_a_pose_found_wrong_is_stopped():
    console = Console("thesis", odometers="increments")
    console.run(TICK)
    ended: list[MissionEnd] = []
    console.loop.run_mission(Straight(), ended.append)
    console.run(4.0)
    assert ended and ended[0].outcome is Outcome.LOST and "its pose was wrong" in ended[0].why
    assert console.board.true_pose.x < 1.0
    console.run(1.0)
    assert not console.link.bulk().moving
    assert console.error()[0] <= 0.01


def test_a_typed_get_bulk_data_does_not_lose_a_later_board_s_travel():
    console = Console("later")
    console.run(TICK)
    console.loop.press(Intent.FORWARD)
    for tick in range(40):
        console.loop.press(Intent.FORWARD)
        console.loop.tick()
        if tick % 5 == 2:
            console.loop.submit(lambda link: link.bulk())  # the operator's `b`
        console.clock.advance(TICK)
    console.run(1.5)
    assert console.board.true_pose.x > 0.5
    assert console.error()[0] <= 0.005


@pytest.mark.parametrize(("firmware", "odometers", "options"), [
    ("later", "auto", ""),
    ("giraff-x", "encoders", ""),
    ("later", "auto", PACED),
])  # fmt: skip
def test_go_reaches_a_room_on_a_later_board(firmware, odometers, options):
    # The missions measure progress and stalls on imdl/imdr as totals: the loop hands
    # them totals whatever the board reports.
    navigator = Navigator(PLAN, walls_of(PLAN))
    console = Console(firmware, odometers=odometers, options=options)
    start = navigator.start_pose
    assert start is not None
    site = SimulatedSite(console.board, PLAN, start)
    console.loop.odometry.reset(start)
    console.run(TICK)  # connected
    ended: list[MissionEnd] = []
    mission = GoTo(navigator, "bathroom", lambda: console.loop.odometry.pose, tick=TICK,
                   limits=LIMITS, sense=site.range_finder.readings)  # fmt: skip
    console.loop.run_mission(mission, ended.append)
    end = console.clock.now() + 400
    while not ended and console.clock.now() < end:
        console.loop.tick()
        console.clock.advance(TICK)
    assert len(ended) == 1 and ended[0].outcome.arrived, console.reports
    # Checked against cdis on the way, and found right: no alarm.
    assert not any(r.startswith("odometry") for r in console.reports), console.reports
    truth = site.true_pose()
    goal = PLAN.rooms["bathroom"]
    assert math.hypot(truth.x - goal.at[0], truth.y - goal.at[1]) <= 0.03
    if goal.heading is not None:
        turn = math.remainder(truth.heading - math.radians(goal.heading), math.tau)
        assert abs(math.degrees(turn)) <= 2.0
    assert console.error()[0] <= 0.01


@pytest.mark.parametrize("firmware", PROFILES)
def test_travel_while_the_link_was_lost_is_counted_and_the_board_not_checked_again(firmware):
    console = Console(firmware)
    port = console.link.port
    cable = {"plugged": True}

    def connect() -> BoardLink:
        if not cable["plugged"]:
            raise LinkDisconnected("cable unplugged")
        if not port.is_open:
            port.open()
        # A board that stayed powered (a pty, a cable put back): no pulse and no greeting
        # (the simulator greets whenever its port opens), so it keeps its counters.
        port.reset_input_buffer()
        link = BoardLink(port, clock=console.clock)
        link.handshake(power_line="none", timeout=0.1)
        return link

    console.loop.connect = connect
    console.hold(Intent.FORWARD, 2.0)  # checked within the first metre
    assert console.loop.feed.check is None
    console.loop.press(Intent.FORWARD)
    console.run(0.5)
    cable["plugged"] = False
    port.close()  # the cable comes out while the robot drives...
    console.run(1.0)
    cable["plugged"] = True
    for _ in range(100):  # back-off: retries come at most 4 s apart
        console.run(TICK)
        if console.loop.link is not None:
            break
    assert console.loop.link is not None
    restored = [r for r in console.reports if r.startswith("link restored")]
    assert len(restored) == 1
    # It did not greet: a board met again, as it answers to the probe.
    assert restored[0].startswith("link restored; robot commanded to stop; board version "
                                  "unknown: ")  # fmt: skip
    assert console.loop.feed.check is None  # the same board, already checked
    console.run(2.0)
    assert console.error()[0] <= 0.01
