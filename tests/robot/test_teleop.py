"""Teleop through the control loop against the simulator on a virtual clock."""

from __future__ import annotations

import math

import pytest

from giraff_console.link import BoardLink, LinkDisconnected, MotorState
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman, Intent
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.robot.teleop import BLOCKED_S, DriveLimits, Teleop, still
from giraff_console.sim.collision import Solids
from giraff_console.sim.surroundings import Surroundings
from tests.listening import notes_into, only

TICK = 0.05


class Console:
    """A control loop stepped by hand, with keys pressed as a terminal would repeat them."""

    def __init__(self) -> None:
        self.link = BoardLink.open("giraff-sim://?clock=virtual")
        self.clock = self.link.port.clock
        self.board = self.link.port.board
        self.sent: list[str] = []
        self.link.add_observer(lambda e: self.sent.append(e.command))
        self.reports: list[str] = []
        self.loop = ControlLoop(
            lambda: self.link, teleop=Teleop(), deadman=Deadman(self.clock),
            clock=self.clock,
        )  # fmt: skip
        self.loop.subscribe(notes_into(self.reports))

    def run(self, seconds: float) -> None:
        end = self.clock.now() + seconds
        while self.clock.now() < end - 1e-9:
            self.loop.tick()
            self.clock.advance(TICK)

    def hold(
        self, intent: Intent, seconds: float, delay: float = 0.5, every: float = 0.033
    ) -> None:
        """Press, wait the initial repeat delay, then repeat every `every` s, ticking at 20 Hz."""
        self.loop.press(intent)
        start = self.clock.now()
        next_press = start + delay
        next_tick = start
        while self.clock.now() < start + seconds:
            if self.clock.now() >= next_tick:
                self.loop.tick()
                next_tick += TICK
            if self.clock.now() >= next_press:
                self.loop.press(intent)
                next_press += every
            self.clock.advance(max(0.0, min(next_tick, next_press) - self.clock.now()))

    def moving(self) -> bool:
        return self.link.bulk().moving


@pytest.fixture
def console() -> Console:
    return Console()


def test_holding_up_for_two_seconds_drives_0_6_to_1_0_metres(console):
    console.hold(Intent.FORWARD, 2.0)
    console.run(2.0)
    assert not console.moving()
    assert 0.6 <= console.board.true_pose.x <= 1.0
    assert console.loop.odometry.pose.x == pytest.approx(console.board.true_pose.x, abs=1e-3)


def test_releasing_stops_within_0_7_s_of_the_last_repeat(console):
    console.hold(Intent.FORWARD, 2.0)
    released = console.clock.now()
    console.sent.clear()
    while not any(c.startswith("set p") for c in console.sent):
        console.run(TICK)
    assert console.clock.now() - released <= 0.7
    console.run(1.5)
    assert not console.moving()
    assert console.link.bulk().cdis > 0  # braked forward: no reversal


def test_a_single_tap_stops_after_the_grace_period(console):
    console.loop.press(Intent.FORWARD)
    console.run(0.5)
    assert console.moving()
    console.run(2.0)
    assert not console.moving()
    assert console.board.true_pose.x < 0.25


def test_a_console_that_dies_at_full_speed_lets_the_robot_run_at_most_0_3_m(console):
    console.hold(Intent.FORWARD, 3.0)  # cruising at 0.4 m/s
    assert console.link.bulk().speed == pytest.approx(0.4, abs=1e-6)
    died_at = console.board.true_pose.x
    console.clock.advance(10)  # no more ticks: the board runs on its last set p
    assert console.board.true_pose.x - died_at <= 0.3


def test_forward_right_drives_a_curve_with_the_gear_ratio_capped(console):
    console.hold(Intent.FORWARD_RIGHT, 3.0)
    state = console.link.bulk()
    assert 0 < state.cvg < 0.51
    assert console.board.true_pose.heading < -math.radians(10)  # turning clockwise
    console.run(2.0)
    assert not console.moving()


def test_turning_alone_rotates_in_place(console):
    console.hold(Intent.LEFT, 2.0)
    console.run(2.0)
    pose = console.board.true_pose
    assert math.degrees(pose.heading) > 30  # counter-clockwise
    assert math.hypot(pose.x, pose.y) < 1e-9


def test_switching_from_driving_to_turning_stops_first(console):
    console.hold(Intent.FORWARD, 1.5)
    console.hold(Intent.RIGHT, 2.0)
    console.run(2.0)
    assert console.board.true_pose.heading < -math.radians(20)
    assert not console.moving()


def test_estop_stops_teleop_and_is_reported(console):
    console.hold(Intent.FORWARD, 1.0)
    console.board.set_estop(True)
    console.run(0.1)
    console.sent.clear()
    console.hold(Intent.FORWARD, 0.5)
    assert any("ESTOP" in report for report in console.reports)
    assert not [command for command in console.sent if command.startswith("set p")]


def test_a_lost_link_is_reported_then_reconnected_with_a_stop_first(console):
    telemetry = []
    console.loop.subscribe(only(Telemetry, telemetry.append))
    port = console.link.port
    cable = {"plugged": True}

    def connect() -> BoardLink:
        if not cable["plugged"]:
            raise LinkDisconnected("cable unplugged")
        if not port.is_open:
            port.open()
        link = BoardLink(port, clock=console.clock)
        # No power pulse, as on a pty: a pulse would reboot the board and stop it anyway.
        link.handshake(power_line="none", timeout=0.1)
        link.add_observer(lambda e: console.sent.append(e.command))
        return link

    console.loop.connect = connect
    console.hold(Intent.FORWARD, 2.0)
    cable["plugged"] = False
    port.close()  # the cable comes out while the robot cruises...
    console.board.execute("set p 5")  # ...and the board has a long way to go
    console.run(1.0)
    assert telemetry[-1].link is LinkState.LOST
    assert any("LINK LOST" in report for report in console.reports)
    cable["plugged"] = True
    console.sent.clear()
    for _ in range(60):  # back-off: retries come at most 4 s apart
        console.run(TICK)
        if telemetry[-1].link is LinkState.CONNECTED:
            break
    assert telemetry[-1].link is LinkState.CONNECTED
    stop = ["get bulk_data", "get r", "set mode 0", "set a 0.5", "set cdp 0"]
    assert console.sent[:5] == stop
    assert console.sent[5].startswith("set p ")
    console.run(2.0)
    assert not console.moving()


def test_limits_refuse_speeds_that_break_the_runaway_rule():
    with pytest.raises(ValueError, match=r"0\.25 m"):
        DriveLimits(max_speed=0.6, speed=0.6)
    with pytest.raises(ValueError):
        DriveLimits(max_gear=0.6)


def test_speed_keys_stay_within_the_caps():
    teleop = Teleop()
    assert teleop.set_speed(5) == 0.4
    assert teleop.set_speed(-1) == 0.05


def test_a_board_that_restarts_keeps_the_pose_and_is_reported(console):
    console.hold(Intent.FORWARD, 2.0)
    console.run(2.0)
    x = console.loop.odometry.pose.x
    console.link.port.dtr = False
    console.link.port.dtr = True  # the board reboots: odometers back to zero
    console.run(0.2)
    assert any("restarted" in report for report in console.reports)
    assert console.loop.odometry.pose.x == pytest.approx(x, abs=1e-6)


def test_a_restart_found_by_a_typed_command_leaves_the_board_s_settings_unknown(console):
    from giraff_console.protocol import Command

    console.run(0.2)
    assert console.loop.teleop.board_settings  # set within the limits as it connected
    console.link.port.dtr = False
    console.link.port.dtr = True  # the board reboots: back at v = a = 0.6, vg = 1
    # A typed command goes before the tick's poll, and so finds the restart: the loop
    # must hear of it, or the guard goes on checking moves by settings now gone.
    console.loop.submit(lambda link: link.send(Command("get", "v")))
    console.run(0.1)
    assert any("restarted" in report for report in console.reports)
    assert console.loop.teleop.board_settings == {}


def test_a_stop_reads_the_style_so_a_turn_is_never_stopped_with_metres():
    from giraff_console.link import MotorState
    from giraff_console.robot.safety import stop_commands

    turning = MotorState(cang=0.0, cdis=0.0, gvr=-45.0, speed=-45.0, cvg=0.0, tilt=None,
                         imdl=0.0, imdr=0.0, mode=128, received_at=0.0)  # fmt: skip
    target = float(stop_commands(turning, r=0)[-1].value)
    assert 0 < target < 69  # degrees, within 0.3 m of wheel travel
    assert float(stop_commands(turning, r=1000)[-1].value) <= 0.3  # capped whatever the reading


def test_the_target_is_renewed_only_when_the_robot_gets_close(console):
    console.hold(Intent.FORWARD, 3.0)
    renewals = [c for c in console.sent if c.startswith("set p")]
    assert 8 <= len(renewals) <= 20  # not once a tick (60 ticks)


def walled(console: Console) -> None:
    """A wall across the way ahead, 1 m in front of the robot's centre."""
    console.board.make_solid(Solids([((1.0, -5.0), (1.0, 5.0))], 0.3, Surroundings()))


def test_let_go_against_a_wall_the_held_up_stop_is_given_up_and_it_backs_off(console):
    walled(console)
    # Let go with the wall nearer than the braking distance: the stop runs into it.
    console.hold(Intent.FORWARD, 1.9)
    console.run(0.5)
    assert console.board.true_pose.x == pytest.approx(0.7, abs=0.01)  # against the wall
    console.run(1.5)
    # The stop could not be made against the wall; it was given up, not left pending.
    assert not console.moving()
    assert "set p 0" in console.sent
    assert not console.loop.teleop.active
    console.hold(Intent.BACKWARD, 1.5)
    console.run(1.5)
    assert console.board.true_pose.x < 0.5


def test_against_a_wall_the_other_way_backs_off_without_letting_go_first(console):
    walled(console)
    console.hold(Intent.FORWARD, 4.0)
    assert console.board.true_pose.x == pytest.approx(0.7, abs=0.01)
    console.hold(Intent.BACKWARD, 1.5)
    assert console.board.true_pose.x < 0.6


def test_holding_up_against_a_wall_is_blocked_and_said_once(console):
    """Up held into a wall: the move is under way and the wheels do not turn; after
    BLOCKED_S the snapshot says blocked and the operator is told once; let go, or
    backing away, and it is not."""
    walled(console)
    shown: list[Telemetry] = []
    console.loop.subscribe(only(Telemetry, shown.append))
    console.hold(Intent.FORWARD, 1.4)  # reaches the wall (0.7 m) after about 1.3 s
    assert not shown[-1].blocked
    console.hold(Intent.FORWARD, 2.5)
    assert console.board.true_pose.x == pytest.approx(0.7, abs=0.01)
    assert shown[-1].blocked
    said = [r for r in console.reports if r.startswith("blocked:")]
    assert said == [f"blocked: the keys drive, but the wheels have not turned for "
                    f"{BLOCKED_S:g} s; something is in the way"]  # fmt: skip
    console.hold(Intent.BACKWARD, 1.0)
    assert not shown[-1].blocked and console.board.true_pose.x < 0.7


def test_driving_freely_is_never_blocked(console):
    shown: list[Telemetry] = []
    console.loop.subscribe(only(Telemetry, shown.append))
    console.hold(Intent.FORWARD, 3.0)
    console.hold(Intent.LEFT, 2.0)
    console.run(2.0)
    assert shown and not any(t.blocked for t in shown)
    assert not any(r.startswith("blocked:") for r in console.reports)


def test_blocked_is_said_once_through_gaps_in_the_key_repeats_and_cleared_by_a_lost_link(
    console,
):
    """Over a jittery SSH link a held key's repeats have gaps longer than the deadman's
    grace: the note is not said again at each, only after the keys let go or the wheels
    turn. A stop that is not the keys' (the link lost) leaves nothing blocked."""
    walled(console)
    shown: list[Telemetry] = []
    console.loop.subscribe(only(Telemetry, shown.append))
    console.hold(Intent.FORWARD, 4.0)
    for _ in range(4):
        console.run(0.25)  # a gap in the repeats
        console.hold(Intent.FORWARD, 2.0, delay=0.03)
    assert shown[-1].blocked
    assert sum(r.startswith("blocked:") for r in console.reports) == 1
    console.loop.teleop.forget_board()  # a new connection: teleop starts afresh
    console.run(0.5)
    assert not shown[-1].blocked


def test_a_reading_that_is_not_a_number_is_not_still():
    for gvr, still_ in ((0.0, True), (9e-16, True), (0.01, False), (math.nan, False)):
        state = MotorState(0.0, 0.0, gvr, gvr, 0.0, None, 0.0, 0.0, 0, 0.0)
        assert still(state) is still_
