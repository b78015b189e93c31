"""Patrol files, and patrols run against a made-up robot on a virtual clock."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from giraff_console.link.motor_state import MotorState
from giraff_console.missions.names import list_patrols, patrol_file
from giraff_console.missions.patrol import (
    PatrolError,
    PatrolRun,
    Stop,
    StopReached,
    load_patrol,
)
from giraff_console.missions.route import PathSample, Route, TimedCommand
from giraff_console.protocol.codec import parse_command
from giraff_console.protocol.mode import ModeBit
from giraff_console.robot.localisation import Estimate, PoseBasis
from giraff_console.robot.odometry import Pose

TICK = 0.1
# The made-up robot keeps moving this long after each `set p`.
COASTS = 1.0


def write(tmp_path, document, name="rounds") -> object:
    path = tmp_path / f"{name}.patrol.yaml"
    path.write_text(document if isinstance(document, str) else yaml.safe_dump(document))
    return path


def route(name: str, duration: float, *offsets: float) -> Route:
    commands = [TimedCommand(offset, parse_command("set p 0.2")) for offset in offsets]
    return Route(name, "T", None, {"v": "0.3"}, commands, [], [], duration)


ROUTES = {
    "hall-to-kitchen": route("hall-to-kitchen", 4.0, 0.0, 2.0),
    "kitchen-to-hall": route("kitchen-to-hall", 3.0, 0.0, 1.0),
}
STOPS = [{"route": "hall-to-kitchen", "dwell": 10}, {"route": "kitchen-to-hall", "dwell": 5}]


def rounds(tmp_path, number=2):
    return load_patrol(write(tmp_path, {"rounds": number, "stops": STOPS}))


class Robot:
    """Moves for COASTS seconds after every `set p`, its wheels turning; polled every
    tick."""

    def __init__(self, run: PatrolRun) -> None:
        self.run = run
        self.now = 0.0
        self.moving_until = -1.0
        self.sent: list[tuple[float, list[str]]] = []

    def tick(self) -> list[str]:
        mode = int(ModeBit.MOVING) if self.now < self.moving_until else 0
        # The wheels turn while it moves, so that a replay sees no stall (route_replay.py).
        wheels = 0.3 * self.now
        state = MotorState(0.0, 0.0, 0.0, 0.0, 0.0, None, wheels, wheels, mode, self.now)
        commands = [command.text for command in self.run.step(self.now, state)]
        if any(text.startswith("set p") for text in commands):
            self.moving_until = self.now + COASTS
        if commands:
            self.sent.append((self.now, commands))
        self.now = round(self.now + TICK, 9)
        return commands

    def run_until(self, end: float) -> None:
        while self.now < end and not self.run.finished:
            self.tick()


def test_a_patrol_file_loads(tmp_path):
    patrol = rounds(tmp_path)
    assert (patrol.name, patrol.rounds, patrol.snapshots) == ("rounds", 2, True)
    assert patrol.stops == [Stop("hall-to-kitchen", 10.0), Stop("kitchen-to-hall", 5.0)]
    quiet = load_patrol(write(tmp_path, {"rounds": 1, "snapshots": False,
                                         "stops": [{"route": "a"}]}, "quiet"))  # fmt: skip
    assert (quiet.snapshots, quiet.stops) == (False, [Stop("a", 0.0)])
    assert list_patrols(tmp_path) == ["quiet", "rounds"]


def test_a_stop_names_a_route_or_a_room(tmp_path):
    path = write(tmp_path, {"rounds": 1, "stops": [
        {"room": "kitchen", "dwell": 5}, {"route": "hall", "follow": True}]})  # fmt: skip
    patrol = load_patrol(path)
    assert [stop.place for stop in patrol.stops] == ["kitchen", "hall"]
    assert patrol.stops[0].room == "kitchen" and patrol.stops[0].route is None
    assert patrol.stops[1].follow and patrol.stops[1].room is None
    both = write(tmp_path, {"rounds": 1, "stops": [{"room": "kitchen", "route": "hall"}]})
    with pytest.raises(PatrolError, match=r"stops\[0\]: a stop names either a route or a room"):
        load_patrol(both)
    room_follow = write(tmp_path, {"rounds": 1, "stops": [{"room": "kitchen", "follow": True}]})
    with pytest.raises(PatrolError, match=r"follow should be true or false, and only for a route"):
        load_patrol(room_follow)


def test_rooms_in_a_patrol_need_a_floor_plan(tmp_path):
    patrol = load_patrol(write(tmp_path, {"rounds": 1, "stops": [{"room": "kitchen"}]}))
    with pytest.raises(PatrolError, match="needs a floor plan"):
        PatrolRun(patrol, {})


@pytest.mark.parametrize(
    ("document", "complaint"),
    [
        ("rounds: [", "not YAML"),
        ({"stops": STOPS}, "missing key rounds"),
        ({"rounds": 0, "stops": STOPS}, "rounds should be a whole number"),
        ({"rounds": "two", "stops": STOPS}, "rounds should be a whole number"),
        ({"rounds": 1, "stops": []}, "stops should be a list"),
        ({"rounds": 1, "stops": STOPS, "snapshot": False}, "unknown key snapshot"),
        ({"rounds": 1, "snapshots": "yes please", "stops": STOPS}, "snapshots should be true"),
        ({"rounds": 1, "stops": [{"dwell": 5}]}, "stops[0]: a stop names either a route or"),
        ({"rounds": 1, "stops": [{"route": "a", "dwell": -1}]}, "stops[0].dwell is -1"),
        ({"rounds": 1, "stops": ["a"]}, "stops[0] should be a mapping"),
    ],
)
def test_a_malformed_patrol_file_is_refused_with_the_file_and_key_named(
    tmp_path, document, complaint
):
    path = write(tmp_path, document)
    with pytest.raises(PatrolError) as refused:
        load_patrol(path)
    assert str(path) in str(refused.value)
    assert complaint in str(refused.value)


def test_a_patrol_needs_all_its_routes(tmp_path):
    with pytest.raises(PatrolError, match="kitchen-to-hall"):
        PatrolRun(rounds(tmp_path), {"hall-to-kitchen": ROUTES["hall-to-kitchen"]})


def test_a_patrol_drives_each_stop_of_each_round_and_dwells_there(tmp_path):
    reached: list[tuple[float, StopReached]] = []
    run = PatrolRun(rounds(tmp_path), ROUTES, lambda stop: reached.append((robot.now, stop)))
    robot = Robot(run)
    robot.run_until(200.0)
    assert run.finished
    assert [stop for _, stop in reached] == [
        StopReached(1, 1, "hall-to-kitchen"),
        StopReached(1, 2, "kitchen-to-hall"),
        StopReached(2, 1, "hall-to-kitchen"),
        StopReached(2, 2, "kitchen-to-hall"),
    ]
    # Each route's settings go out once its dwell is over, and not a tick later.
    starts = [at for at, commands in robot.sent if commands[0] == "set v 0.3"]
    assert starts[0] == 0.0
    for (stopped, stop), started in zip(reached, starts[1:], strict=False):
        dwell = 10.0 if stop.stop_index == 1 else 5.0
        assert stopped + dwell <= started < stopped + dwell + TICK + 1e-9
    # A stop is reached once the last `set p` has been sent and the robot has come to rest.
    assert reached[0][0] == pytest.approx(2.0 + COASTS)


def test_a_patrol_finishes_only_when_the_last_dwell_is_over(tmp_path):
    reached: list[float] = []
    run = PatrolRun(rounds(tmp_path, 1), ROUTES, lambda stop: reached.append(robot.now))
    robot = Robot(run)
    robot.run_until(200.0)
    last_stop = reached[-1]
    assert run.next_due() is None
    assert robot.now == pytest.approx(last_stop + 5.0 + TICK)
    again = PatrolRun(rounds(tmp_path, 1), ROUTES)
    robot = Robot(again)
    robot.run_until(last_stop + 5.0 - TICK / 2)
    assert not again.finished
    assert again.next_due() == pytest.approx(last_stop + 5.0)


def test_patrol_progress_names_round_and_stop_and_counts_down(tmp_path):
    run = PatrolRun(rounds(tmp_path), ROUTES)
    first = run.progress
    assert (first.name, first.state, first.eta_s) == (
        "patrol rounds", "round 1/2, stop 1/2 (hall-to-kitchen)", 44.0,
    )  # fmt: skip
    robot = Robot(run)
    seen = [first]
    while not run.finished:
        robot.tick()
        seen.append(run.progress)
    lines = [progress.line() for progress in seen]
    assert lines[0] == "patrol rounds: round 1/2, stop 1/2 (hall-to-kitchen), 44 s left"
    assert "patrol rounds: round 2/2, stop 2/2 (kitchen-to-hall), 5 s left" in lines
    left = [progress.eta_s for progress in seen[:-1]]
    assert left == sorted(left, reverse=True)
    assert 0 <= left[-1] <= TICK + 1e-9  # the last tick of the last dwell
    assert lines[-1] == "patrol rounds: done, 2 rounds" and seen[-1].eta_s is None


def test_a_patrols_progress_carries_its_stops_until_it_has_arrived(tmp_path):
    run = PatrolRun(rounds(tmp_path), ROUTES, lambda stop: None)
    robot = Robot(run)
    robot.tick()
    robot.tick()
    stop = run.progress.detail
    assert stop is not None and stop.name == "route hall-to-kitchen"
    assert stop.eta_s == pytest.approx(4.0 - TICK)
    # The stop's own line is not the patrol's: logs read that as it has always been.
    assert run.progress.line().endswith("(hall-to-kitchen), 44 s left")
    while run.next_due() is None or run.next_due() - robot.now < 5.0:
        robot.tick()  # until the first dwell has begun
    assert run.progress.detail is None


def test_long_patrols_count_in_minutes(tmp_path):
    patrol = load_patrol(write(tmp_path, {"rounds": 1, "stops": [
        {"route": "hall-to-kitchen", "dwell": 61}]}))  # fmt: skip
    line = PatrolRun(patrol, ROUTES).progress.line()
    assert line.endswith("(hall-to-kitchen), 1 min 05 s left")


def test_a_paused_patrol_freezes_its_dwell(tmp_path):
    run = PatrolRun(rounds(tmp_path), ROUTES, lambda stop: None)
    robot = Robot(run)
    while run.next_due() is None or run.next_due() - robot.now < 5.0:
        robot.tick()  # until the first dwell has begun
        assert robot.now < 20.0
    dwell_end = run.next_due()
    run.pause(robot.now)
    left = run.progress.eta_s
    for _ in range(600):
        assert robot.tick() == []
    assert run.next_due() is None
    assert run.progress.eta_s == left
    run.resume(robot.now)
    assert run.next_due() == pytest.approx(dwell_end + 60.0)


def test_a_paused_patrol_pauses_the_route_it_is_driving(tmp_path):
    run = PatrolRun(rounds(tmp_path), ROUTES)
    robot = Robot(run)
    robot.tick()  # settings and the first `set p`, at 0
    run.pause(0.5)
    assert run.step(20.0, None) == []
    assert run.next_due() is None
    run.resume(30.5)
    assert run.next_due() == pytest.approx(32.0)
    assert [c.text for c in run.step(31.0, None)] == ["set v 0.3"]  # the settings, restored
    assert [c.text for c in run.step(32.0, None)] == ["set p 0.2"]


def estimate(basis: PoseBasis, found: bool = False) -> Estimate:
    pose = Pose(0.0, 0.0, 0.0)
    covariance = ((0.0025, 0.0, 0.0), (0.0, 0.0025, 0.0), (0.0, 0.0, 0.003))
    return Estimate(pose, pose, covariance, 0.05, 0.05, (0.05, 0.05, 0.0), found=found,
                    basis=basis)  # fmt: skip


@pytest.mark.parametrize(("basis", "found", "drives"), [
    (PoseBasis.ASSUMED, False, False),  # a daemon restarted from the pose it kept
    (PoseBasis.ASSUMED, True, True),  # a marker has found it since
    (PoseBasis.GIVEN, False, True),  # the operator placed it
])  # fmt: skip
def test_a_taught_route_is_never_replayed_from_a_pose_only_assumed(tmp_path, basis, found,
                                                                  drives):  # fmt: skip
    run = PatrolRun(rounds(tmp_path, 1), ROUTES, estimate=lambda: estimate(basis, found))
    robot = Robot(run)
    robot.run_until(30.0)
    if drives:
        assert run.finished and run.problem is None and robot.sent
    else:
        assert not robot.sent
        assert run.problem is not None and "only assumed" in run.problem
        assert "hall-to-kitchen" in run.problem


@pytest.mark.parametrize(("start", "drives"), [
    (PathSample(0.0, 0.5, 0.0, 0.0), True),  # half a metre off: within the reach
    (PathSample(0.0, 3.0, 0.0, 0.0), False),  # where a stop before it failed, say
    (PathSample(0.0, 0.0, 0.0, 0.6), False),  # there, but turned 34 degrees away
])  # fmt: skip
def test_a_taught_route_is_replayed_only_from_near_where_it_starts(tmp_path, start, drives):
    taught = {name: replace(one, path=[start]) for name, one in ROUTES.items()}
    run = PatrolRun(rounds(tmp_path, 1), taught,
                    estimate=lambda: estimate(PoseBasis.MARKER, found=True))  # fmt: skip
    robot = Robot(run)
    robot.run_until(30.0)
    if drives:
        assert run.problem is None and robot.sent
    else:
        assert not robot.sent
        assert run.problem is not None and "from where route" in run.problem


def test_a_patrol_is_found_in_the_routes_folder_before_the_examples(tmp_path):
    mine, examples = tmp_path / "routes", tmp_path / "examples"
    mine.mkdir()
    examples.mkdir()
    document = {"rounds": 1, "stops": STOPS}
    write(examples, document, "night")
    assert patrol_file("night", (mine, examples)) == examples / "night.patrol.yaml"
    write(mine, document, "night")
    assert patrol_file("night", (mine, examples)) == mine / "night.patrol.yaml"


def test_a_patrol_found_nowhere_is_the_routes_folders_for_the_error(tmp_path):
    assert patrol_file("day", (tmp_path / "a", tmp_path / "b")) == tmp_path / "a/day.patrol.yaml"


def test_a_patrol_files_path_is_taken_as_it_is(tmp_path):
    assert patrol_file("elsewhere/x.patrol.yaml", (tmp_path,)) == Path("elsewhere/x.patrol.yaml")


def test_a_patrols_brief_state_leaves_out_the_place_and_a_single_round(tmp_path):
    assert PatrolRun(rounds(tmp_path), ROUTES).progress.brief == "round 1/2, stop 1/2"
    one = load_patrol(write(tmp_path, {"rounds": 1, "stops": STOPS}, "one"))
    assert PatrolRun(one, ROUTES).progress.brief == "stop 1/2"
