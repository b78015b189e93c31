"""A path mission that gets no nearer gives up, stops the robot and says what to do; its
progress line never shows what is not so. In the simulated care home, on a virtual clock.

`Hemmed` stands for something the range finder reports in the way at every look, which
no new plan gets round (a person who keeps stepping in front of the robot): the mission
stops, plans again and stops again, as it did beside a box in issue 12.
"""

from __future__ import annotations

import math

import pytest

from giraff_console.missions.go_to import GoTo
from giraff_console.missions.lookout import Lookout
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.path_mission import STAGE_LIMITS, Stage
from giraff_console.missions.progress_watch import PROGRESS_M, Patience, ProgressWatch
from giraff_console.motion.executor import Executor
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.mission import Outcome
from giraff_console.robot.odometry import Pose
from giraff_console.settings import SettingsError, load_settings
from giraff_console.sim.drive import TruePose
from tests.missions.site import LIMITS, PLAN, TICK, Site


@pytest.fixture
def navigator() -> Navigator:
    return Navigator(PLAN, walls_of(PLAN))


class HemmedLookout(Lookout):
    """A lookout that finds the path ahead blocked at every sweep while `hemmed`."""

    hemmed = False

    def blocks(self, executor: Executor) -> bool:
        return self.hemmed or super().blocks(executor)


class Hemmed(GoTo):
    """A `go` whose path ahead is blocked at every look while `hemmed` is set."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        assert self.navigator is not None and self._lookout is not None
        self._lookout = HemmedLookout(self.navigator, self._lookout.sense)
        self._lookout.new_plan(self.planned)

    @property
    def hemmed(self) -> bool:
        assert isinstance(self._lookout, HemmedLookout)
        return self._lookout.hemmed

    @hemmed.setter
    def hemmed(self, value: bool) -> None:
        # The path is looked at only once the range finder has seen something: let it
        # have seen a chair in room 101, far from every way driven here.
        assert self.navigator is not None and isinstance(self._lookout, HemmedLookout)
        self.navigator.report_obstacles([(2.0, 16.5)])
        self._lookout.hemmed = value


def hemmed_go(site: Site, room: str, patience: Patience) -> Hemmed:
    mission = Hemmed(site.navigator, room, site.pose, tick=TICK, limits=LIMITS,
                     sense=site.sense, patience=patience)  # fmt: skip
    return site.start(mission)


def assert_stays_stopped(site: Site) -> None:
    before = site.true_pose()
    site.run(5, until_ended=False)
    after = site.true_pose()
    assert site.board.drive.velocity == 0
    assert math.dist((before.x, before.y), (after.x, after.y)) < 1e-6


# -- the watch on its own --------------------------------------------------------------


def test_the_watch_is_stuck_after_stuck_s_without_progress():
    watch = ProgressWatch(Patience(stuck_s=30, max_replans=5), now=0.0, left=10.0)
    watch.driven(20.0, 10.0 - PROGRESS_M / 2)  # a creep is not progress
    assert not watch.stuck(29.9)
    assert watch.stuck(30.0)


def test_progress_restarts_the_watch():
    watch = ProgressWatch(Patience(stuck_s=30, max_replans=5), now=0.0, left=10.0)
    watch.driven(25.0, 9.0)
    assert not watch.stuck(50.0) and watch.stuck(55.0)


def test_replans_in_a_row_without_progress_run_out_and_progress_resets_them():
    watch = ProgressWatch(Patience(stuck_s=30, max_replans=2), now=0.0, left=10.0)
    watch.replanned(25.0)  # a longer way round is not a step back...
    assert not watch.out_of_replans()
    watch.driven(5.0, 24.0)  # ...and getting along it is progress
    watch.replanned(24.0)
    watch.replanned(24.0)
    assert watch.out_of_replans()


@pytest.mark.parametrize("stuck_s, max_replans", [(0, 5), (-1, 5), (math.nan, 5), (30, 0),
                                                   (30, 2.5), (1e9, 5)])  # fmt: skip
def test_nonsense_patience_is_refused(stuck_s, max_replans):
    with pytest.raises(ValueError, match="motion"):
        Patience(stuck_s, max_replans)


# -- in the care home ------------------------------------------------------------------


def test_a_go_hemmed_in_stops_after_max_replans_and_says_what_to_do(navigator):
    site = Site(navigator)
    mission = hemmed_go(site, "room-113", Patience(stuck_s=600, max_replans=3))
    site.run(20)
    mission.hemmed = True
    hemmed_at = site.clock.now()
    site.run(120)
    assert site.ended, "a mission that gets no nearer must end"
    assert site.clock.now() - hemmed_at < 60
    why = site.ended[0]
    assert why.startswith("stopped: stuck near (")
    assert "after 3 new ways in a row that got no nearer" in why
    assert "type go room-113 again, or drive by hand" in why
    assert mission.replans == 3
    assert_stays_stopped(site)


def test_a_go_hemmed_in_stops_within_stuck_s_and_says_where(navigator):
    site = Site(navigator)
    mission = hemmed_go(site, "room-113", Patience(stuck_s=10, max_replans=1000))
    site.run(20)
    mission.hemmed = True
    hemmed_at = site.clock.now()
    site.run(120)
    assert site.ended and site.ended[0].startswith("stopped: stuck for 10 s near (")
    # No progress since about when it was hemmed in (less the braking), and not later.
    assert site.clock.now() - hemmed_at <= 10 + 2 * TICK
    pose = site.pose()
    assert f"near ({pose.x:.1f}, {pose.y:.1f})" in site.ended[0]
    assert_stays_stopped(site)


def test_a_way_cleared_in_time_is_driven_to_the_end(navigator):
    site = Site(navigator)
    mission = hemmed_go(site, "room-113", Patience(stuck_s=30, max_replans=5))
    site.run(20)
    mission.hemmed = True
    while mission.replans < 3 and not site.ended:
        site.run(TICK)
    mission.hemmed = False  # they stepped aside
    site.run(400)
    assert site.ended == ["done"]
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), PLAN.rooms["room-113"].at) <= 0.03


def test_while_replanning_the_progress_says_so_and_shows_no_braking_metres(navigator):
    site = Site(navigator)
    mission = hemmed_go(site, "room-113", Patience())
    site.run(20)
    mission.hemmed = True
    seen = []
    while mission.replans < 2 and not site.ended:
        site.run(TICK)
        seen.append(mission.progress)
    mission.hemmed = False
    stopping = [p for p in seen if p.state == "stopping to plan a new way (something in the way)"]
    assert stopping and all(p.left_m is None and p.eta_s is None for p in stopping)
    assert all("m left" not in p.line() and "no ETA" in p.line() for p in stopping)
    # Whatever gives metres left gives the plan under way's, never the brake's 0.1 m.
    site.run(TICK)
    left = mission.executor.remaining()
    assert mission.progress.left_m == left and left > 20
    assert f"{left:.1f} m left" in mission.progress.line()


def test_a_box_put_down_beside_the_robot_does_not_hold_it_for_ever(navigator):
    """Issue 12: a box beside the robot blocked the grid under the robot itself, so every
    new way looked blocked at once. It now drives out of the box's margin and round."""
    site = Site(navigator)
    site.board.place(TruePose(42.0, 11.0, 0.0))  # in the east hall
    site.control.odometry.reset(Pose(42.0, 11.0, 0.0))
    site.control.tick()
    mission = hemmed_go(site, "kitchen", Patience())
    site.run(1)
    site.site.surroundings.block(42.0, 10.4)  # between the robot and the kitchen door
    site.run(200)
    assert site.ended == ["done"]
    assert mission.replans <= 2
    pose = site.true_pose()
    assert math.dist((pose.x, pose.y), PLAN.rooms["kitchen"].at) <= 0.03


@pytest.mark.parametrize("table, message", [("stuck_s = 0", "motion.stuck_s"),
                                            ("max_replans = 2.5", "motion.max_replans"),
                                            ("stuck_s = nan", "motion.stuck_s")])  # fmt: skip
def test_the_settings_file_refuses_nonsense_patience(tmp_path, table, message):
    path = tmp_path / "config.toml"
    path.write_text(f"[motion]\n{table}\n", encoding="utf-8")
    with pytest.raises(SettingsError, match=message):
        load_settings(path)


def test_the_settings_file_sets_the_patience(tmp_path):
    path = tmp_path / "config.toml"
    path.write_text("[motion]\nstuck_s = 45\nmax_replans = 8\n", encoding="utf-8")
    assert load_settings(path).motion.patience() == Patience(45, 8)


@pytest.mark.parametrize(("stage", "outcome"), [
    (Stage.LOOKING, Outcome.LOST),
    (Stage.BACKING_OFF, Outcome.STALLED),
])  # fmt: skip
def test_a_look_or_a_back_off_that_never_ends_is_ended_at_its_limit(navigator, stage, outcome):
    # The progress watch does not time these stages; each has a limit of its own, so
    # that a turn hunting round its end, or a reverse that never gets there, ends.
    mission = GoTo(navigator, "room-101", lambda: navigator.start_pose, tick=TICK, limits=LIMITS)
    limit, _ = STAGE_LIMITS[stage]
    mission._stage = stage
    assert mission._overstayed(10.0) is None
    assert mission._overstayed(10.0 + limit) is None
    ended = mission._overstayed(10.0 + limit + TICK)
    assert ended is not None and ended[0] is outcome and "took over" in ended[1]


def test_a_go_hemmed_in_before_it_sets_off_stops_too(navigator):
    # Blocked at the first look, every new plan is blocked again before the robot has
    # moved: each one still counts, or the mission stops and plans for ever (seen with
    # a lidar in a mapped home: 200 stops in a doorway, and no end).
    site = Site(navigator)
    mission = hemmed_go(site, "room-113", Patience(stuck_s=600, max_replans=3))
    mission.hemmed = True
    site.run(120)
    assert site.ended, "a mission that gets no nearer must end"
    why = site.ended[0]
    assert why.startswith("stopped: stuck near (")
    assert "after 3 new ways in a row that got no nearer" in why
    assert_stays_stopped(site)
