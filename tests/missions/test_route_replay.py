"""A taught route replayed in the simulated care home: a stall is reported as a stall.

Open-loop, a replay cannot see what is in its way. Until issue 26 a replay whose robot
was held (a box in front of it, or its wheels stalled) sent the rest of its commands
into the wall and said "done" once the board's move was given up, though its last leg
never moved. Now it watches the wheels as a path mission does, and ends STALLED.
"""

from __future__ import annotations

import math

import pytest

from giraff_console.missions.navigation import Navigator
from giraff_console.missions.route import Route, TimedCommand
from giraff_console.missions.route_replay import RouteReplay
from giraff_console.planning.route_planner import walls_of
from giraff_console.protocol.codec import parse_command
from giraff_console.protocol.mode import ModeBit
from giraff_console.robot.loop_events import MissionChanged
from giraff_console.robot.mission import MissionEnd, Outcome
from tests.listening import only
from tests.missions.site import PLAN, Site

BOARD = {"r": "1000", "mode": "0", "a": "0.5", "v": "0.3", "vg": "0", "vgr": "1", "cdp": "0"}


def out_of_the_dock() -> Route:
    """Straight ahead (north) out of the dock for 4 s, as teleop renews it, then the
    target of nothing teleop sends to give up a move held up (robot/teleop.py): the end
    of a route taught against something, which the board ends at once."""
    commands = [TimedCommand(0.1 * i, parse_command("set p 0.2")) for i in range(1, 40)]
    commands.append(TimedCommand(5.0, parse_command("set p 0")))
    return Route("dock-out", "T", None, BOARD, commands, [], [], 6.0)


@pytest.fixture(scope="module")
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


def replay(site: Site) -> list[MissionEnd]:
    """Replay the route from the dock; how it ended, as the loop told it."""
    ends: list[MissionEnd] = []

    def ended(event: MissionChanged) -> None:
        if event.end is not None:
            ends.append(event.end)

    site.control.subscribe(only(MissionChanged, ended))
    site.start(RouteReplay(out_of_the_dock()))
    site.run(30.0)
    return ends


def test_a_clear_way_is_replayed_to_the_end_and_done(navigator):
    site = Site(navigator)
    start = site.true_pose()
    [end] = replay(site)
    assert site.ended == ["done"] and end.outcome is Outcome.DONE
    assert site.true_pose().y - start.y > 0.8  # it went


def test_a_box_in_front_of_the_robot_ends_the_replay_stalled(navigator):
    site = Site(navigator)
    site.site.surroundings.block(2.0, 7.6, size=0.5)  # just ahead of the dock's robot
    [end] = replay(site)
    assert end.outcome is Outcome.STALLED
    assert site.ended[0].startswith("stopped: stalled")
    assert "the wheels have not turned for 1.0 s" in end.detail
    # The operator reads it in the status log, not "done".
    assert any(note.startswith("dock-out stopped: stalled") for note in site.notes)
    assert not any(note == "dock-out done" for note in site.notes)
    # Ended within a second or so of touching the box, and the robot left at rest.
    assert site.clock.now() < 3.0
    site.run(1.0, until_ended=False)
    assert not site.board.drive.mode_bits() & ModeBit.MOVING


def test_wheels_held_on_a_later_leg_end_the_replay_stalled_there(navigator):
    """The imperfect board's stall (§2.3.2): the wheels stop with the move commanded."""
    site = Site(navigator)
    site.start(RouteReplay(out_of_the_dock()))
    site.run(2.0)
    driven = site.true_pose()
    site.board.stall(60.0)
    site.run(28.0)
    assert site.ended and site.ended[0].startswith("stopped: stalled 3 s into")
    assert math.dist((driven.x, driven.y), (site.true_pose().x, site.true_pose().y)) < 0.01
