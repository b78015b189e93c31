"""The broker killed while two robots drive orders (issue 28): the one whose settings say
`on_broker_lost = "carry_on"` finishes its order, the one that says "stop" stops; both
join the broker again by themselves when it is back, say ONLINE, and report what
happened, in `state` and in their journals, where every line is kept."""

from __future__ import annotations

import math
import time
from contextlib import ExitStack
from pathlib import Path

import pytest

from giraff_console.fleet.broker_link import Broker as BrokerAddress
from giraff_console.fleet.master import FleetMaster, Sent
from giraff_console.fleet.vocabulary import ConnectionState
from giraff_console.planning.floorplan import load_floorplan
from giraff_console.robot.loop_events import Note
from giraff_console.settings import FleetSettings
from tests.fleet.broker import Broker
from tests.fleet.fleet_site import fleet_robots

pytestmark = pytest.mark.timeout(180)

GOAL = "w-14"  # 7 m along the west corridor
BACK_S = 15.0  # paho tries again at most every 4 s
ARRIVAL_M = 0.10


def wait_until(test, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not test():
        assert time.monotonic() < deadline, f"no {what} in {timeout:g} s"
        time.sleep(0.05)


def test_robots_carry_on_or_stop_as_set_and_come_back_when_the_broker_does(
    broker: Broker, wing: Path, tmp_path: Path
):
    plan = load_floorplan(wing)
    with ExitStack() as stack:
        on = stack.enter_context(fleet_robots(broker, wing, tmp_path / "on", 1, prefix="on"))[0]
        halt = stack.enter_context(
            fleet_robots(
                broker,
                wing,
                tmp_path / "halt",
                1,
                fleet=FleetSettings(on_broker_lost="stop"),
                prefix="halt",
            )
        )[0]
        journals: dict[str, list[str]] = {"on": [], "halt": []}
        for name, robot in (("on", on), ("halt", halt)):
            robot.robot.service.subscribe(
                lambda event, name=name: (
                    journals[name].append(event.text) if isinstance(event, Note) else None
                )
            )
        master = stack.enter_context(FleetMaster(BrokerAddress.parse(broker.url)))
        assert master.wait_up(5.0)
        for robot in (on, halt):
            assert (
                master.wait_until(
                    lambda f, r=robot: (v := f.get(r.id)) is not None and v.state is not None, 30.0
                )
                is not None
            )
            assert isinstance(master.go(robot.id, GOAL), Sent)
        wait_until(
            lambda: all(r.robot.true_pose().x < -3.0 for r in (on, halt)),
            60.0,
            "both robots on their way",
        )
        # The states heard before the broker goes; the master keeps them while it is away.
        heard_before = {r.id.name: master.fleet().get(r.id).state.header_id for r in (on, halt)}
        broker.kill()
        killed_at = {r.id.name: r.robot.true_pose() for r in (on, halt)}
        # The one set to stop stops short; the other goes on and arrives, both unheard.
        wait_until(
            lambda: math.dist(_xy(on), plan.rooms[GOAL].at) <= ARRIVAL_M,
            60.0,
            "the carrying-on robot's arrival",
        )
        before = halt.robot.true_pose()
        time.sleep(1.0)
        assert math.dist(_xy(halt), (before.x, before.y)) < 0.005, "the stopping robot moves"
        assert math.dist(_xy(halt), plan.rooms[GOAL].at) > 1.0
        assert math.dist(_xy(halt), (killed_at[halt.id.name].x, killed_at[halt.id.name].y)) < 0.5
        broker.start()
        back = master.wait_until(
            lambda f: all(
                (v := f.get(r.id)) is not None
                and v.connection is ConnectionState.ONLINE
                and v.state is not None
                and v.state.header_id > heard_before[r.id.name]
                and v.state.last_node_id == (GOAL if r is on else v.state.last_node_id)
                for r in (on, halt)
            ),
            BACK_S,
        )
        assert back is not None, "the robots did not come back on the broker"
        on_state, halt_state = back.get(on.id).state, back.get(halt.id).state
        assert on_state.arrived and not on_state.errors
        assert [e.error_type for e in halt_state.errors] == ["brokerLost"]
        for name in ("on", "halt"):
            said = "\n".join(journals[name])
            assert "the broker went" in said and "the broker is back" in said, said
        assert "done at w-14" in "\n".join(journals["on"])
        assert "ended: the broker went" in "\n".join(journals["halt"])


def _xy(robot) -> tuple[float, float]:
    pose = robot.robot.true_pose()
    return pose.x, pose.y
