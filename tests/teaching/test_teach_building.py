"""Teaching a building by driving it once (issue 29): the simulated lidar's bytes read as
a real one's, the map built as a scripted operator drives through every room with
`mark ROOM` in each, saved, planned on at once; on the imperfect simulator, every claim
compared with the truth (tests/teaching/flat.py)."""

from __future__ import annotations

import math
import time

import pytest

from giraff_console.lidar import SIMULATED_LIDAR
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.route_planner import RoutePlanner, walls_of
from giraff_console.planning.scan_grid import read_scan
from giraff_console.robot.loop_events import Note
from giraff_console.robot.mission import Outcome
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service.events import GoReported, MapDrawn, PlanChanged, RouteShown
from giraff_console.settings import Settings
from tests.service.daemon_rig import wait_until
from tests.teaching.flat import ROOMS, write_flat
from tests.teaching.flat import unmapped_plan as dock_only
from tests.teaching.map_truth import map_truth
from tests.teaching.operator import Operator, tour

pytestmark = pytest.mark.timeout(600)

TOUR = ["hall", "lounge", "bedroom", "kitchen"]  # marked from the dock on
DRIVE_S = 450.0  # real seconds the drive may take at --sim-speed 1 on a busy machine
# Real seconds the `go` on the new plan is left to end by itself (it needs about 40);
# then it is stopped, so that the map's tests do not hang on how it drives.
GO_S = 120.0


@pytest.fixture(scope="module")
def taught(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The flat driven round once with the lidar mapping, saved, and a `go` on it."""
    folder = tmp_path_factory.mktemp("flat")
    truth_path = write_flat(folder)
    truth = load_floorplan(truth_path)
    options = RobotOptions(floorplan=dock_only(folder), sim_building=truth_path, sim_speed=1.0,
                           imperfect_seed=3, faults=False, lidar=SIMULATED_LIDAR)  # fmt: skip
    heard: list = []
    with Robot(options, Settings(), truth_path) as robot:
        robot.service.subscribe(heard.append)
        robot.start()
        started = robot.service.execute(c.StartMapping())
        drive = Operator(robot, DRIVE_S).drive(tour(truth, TOUR))
        saved = robot.service.execute(c.SaveMap(folder / "flat-mapped"))
        go = robot.service.execute(c.Go("lounge")) if saved.ok else None
        went = len(heard)
        ended_by_itself = False
        if go is not None and go.ok:
            ended_by_itself = _reported(heard, GO_S)
            if not ended_by_itself:
                robot.service.execute(c.StopMission())
                wait_until(lambda: _reported(heard, 0.0), 10, "the stopped go's report")
        at_end = robot.true_pose()
    return {"folder": folder, "truth": truth, "started": started, "drive": drive,
            "saved": saved, "go": go, "heard": heard, "went": went,
            "ended_by_itself": ended_by_itself, "at_end": at_end}  # fmt: skip


def _reported(heard: list, timeout: float) -> bool:
    """Whether a GoReported is heard within `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while not any(isinstance(e, GoReported) for e in heard):
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)
    return True


def test_mapping_starts_and_every_room_is_marked(taught):
    assert taught["started"].ok, taught["started"].text
    assert taught["drive"].marked == TOUR, [r.text for r in taught["drive"].replies]


def test_the_screens_are_shown_the_map_as_it_grows(taught):
    drawn = [e for e in taught["heard"] if isinstance(e, MapDrawn)]
    # A picture a second at most: the drive takes tens of seconds.
    assert len(drawn) >= 5
    assert len({e.revision for e in drawn}) == len(drawn)


def test_the_map_is_saved_as_ros_reads_it_and_matches_the_building(taught):
    saved, folder = taught["saved"], taught["folder"]
    assert saved.ok, saved.text
    scan = read_scan(folder / "flat-mapped-map.yaml")
    mapped = scan.grid
    truth = walls_of(taught["truth"])
    assert truth is not None
    # Where the map says occupied, the building has a wall or furniture within 0.10 m:
    # 89 to 95 % of the cells in the runs measured at --sim-speed 2 (the drive is in
    # real time, and so not the same twice; at --sim-speed 3, on a busy machine, 71 %,
    # and at 2 beside the suite's heaviest tests 66-72 %: the simulated lidar starves.
    # So the drive runs at the sensor's own pace, --sim-speed 1).
    judged = map_truth(mapped, truth)
    assert judged.inside > 0.99
    assert judged.occupied > 1000 and judged.within_10cm >= 0.80, judged


def test_the_plan_has_a_room_for_each_room_by_the_names_marked(taught):
    folder, truth = taught["folder"], taught["truth"]
    plan = load_floorplan(folder / "flat-mapped.yaml")
    assert set(TOUR) <= set(plan.rooms)
    assert abs(len(plan.rooms) - len(ROOMS)) <= 1, sorted(plan.rooms)
    # Each named room's point is in the real room of that name.
    real = RoutePlanner(truth, walls_of(truth))
    for name in TOUR:
        assert real.room_at(plan.rooms[name].at) == name, (name, plan.rooms[name].at)
    # The start is where the robot started: the dock.
    start = plan.rooms[plan.start]
    assert math.dist(start.at, truth.rooms["hall"].at) < 0.01
    assert any(isinstance(e, PlanChanged) for e in taught["heard"])


def test_go_uses_the_new_plan_at_once(taught):
    """`go lounge` from the kitchen, on the plan just made: the room exists only there,
    and the route is planned from where the map has the robot. Its markers are not
    surveyed yet, so the imperfect robot goes by its estimate and the lidar's fixes,
    and its casters turn it unseen after every turn on the spot: the lidar may see the
    kitchen's doorway off where the map has it, and the mission stop as blocked, or the
    robot clip a 0.8 m doorway's frame until it ends stalled (one clean-clone run of
    six); bench/teach_building.py surveys the markers and measures arrivals. What this
    test holds is that the go is planned on the new plan at once; one that is still at
    its recoveries after GO_S (one clean-clone run) is stopped, and its notes shown."""
    go = taught["go"]
    assert go is not None and go.ok, go
    after = taught["heard"][taught["went"] :]
    # Planned at once on the new plan: a route to the lounge shown.
    assert any(isinstance(e, RouteShown) and e.goal == "lounge" and e.path for e in after)
    ended = [e for e in after if isinstance(e, GoReported)][-1].report
    assert ended.room == "lounge"
    if not taught["ended_by_itself"]:
        notes = [e.text for e in after if isinstance(e, Note)]
        pytest.xfail(f"the go had not ended after {GO_S:g} s; its notes: {notes[-12:]}")
    plan = load_floorplan(taught["folder"] / "flat-mapped.yaml")
    at = taught["at_end"]
    assert ended.end.outcome in (Outcome.ARRIVED, Outcome.ARRIVED_UNVERIFIED, Outcome.BLOCKED,
                                 Outcome.STALLED)  # fmt: skip
    if ended.end.outcome in (Outcome.ARRIVED, Outcome.ARRIVED_UNVERIFIED):
        assert math.dist((at.x, at.y), plan.rooms["lounge"].at) < 0.3
