"""A driver polling the virtual port while the daemon's missions drive (issue 27): every
mission arrives, the daemon's odometry check never alarms (the reset-on-read readings
are shared out), and the driver's stop and idle idioms end none of them.

The robot is built as `serve --sim --firmware later --virtual-port` builds it, its
simulator's clock four times faster than real time so that the test stays short (the
driver polls at its own rate in real time, so it reads once every few of the loop's
ticks: the sharing out is what is tested, not the latency, which bench/virtual_port.py
measures). `bench/virtual_port.py --missions 10` runs ten missions in real time.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from giraff_console.robot.loop_events import MissionChanged, Note
from giraff_console.runtime.options import RobotOptions
from giraff_console.runtime.robot import Robot
from giraff_console.service import commands as c
from giraff_console.service.virtual_port import PROGRAM
from giraff_console.settings import Settings
from tests.drivers.clients import Ros1LikeClient, Ros2LikeClient

pytestmark = pytest.mark.timeout(180)

EXAMPLE = Path(__file__).resolve().parents[2] / "giraff_console/floorplans/care-home.yaml"
WHEEL_BASE_M = 0.499
MISSION_TIMEOUT_S = 60.0
# What the daemon says when no wheel reading agrees with cdis (robot/odometer_check.py).
ALARM = "no wheel reading agrees"


@pytest.mark.parametrize("kind", ["ros2", "ros1"])
def test_a_driver_polling_the_port_leaves_the_daemon_s_missions_alone(ports, kind):
    options = RobotOptions(floorplan=EXAMPLE, firmware="later", virtual_port=True,
                           sim_speed=4.0)  # fmt: skip
    with Robot(options, Settings(), EXAMPLE) as robot:
        ends: list[MissionChanged] = []
        notes: list[str] = []

        def heard(event: object) -> None:
            if isinstance(event, MissionChanged) and not event.running:
                ends.append(event)
            elif isinstance(event, Note):
                notes.append(event.text)

        robot.service.subscribe(heard)
        robot.start()
        assert robot.port is not None
        port = ports(robot.port.path)
        client = (Ros2LikeClient(port, WHEEL_BASE_M) if kind == "ros2"
                  else Ros1LikeClient(port, WHEEL_BASE_M))  # fmt: skip
        client.start()
        done = threading.Event()
        failed: list[BaseException] = []

        def polling() -> None:
            try:
                while not done.is_set():
                    client.idle(1)
            except BaseException as error:  # told below, not lost on the thread
                failed.append(error)

        poller = threading.Thread(target=polling, name="driver", daemon=True)
        poller.start()
        try:
            for room in ("room-101", "dock"):
                asked = len(ends)
                reply = robot.service.execute(c.Go(room))
                assert reply.ok, reply.text
                deadline = time.monotonic() + MISSION_TIMEOUT_S
                while len(ends) == asked and not failed:
                    assert time.monotonic() < deadline, f"go {room} did not end"
                    time.sleep(0.05)
        finally:
            done.set()
            poller.join(10)
    assert not failed, failed
    outcomes = [end.end.outcome.arrived for end in ends if end.end is not None]
    assert outcomes == [True, True], [end.end for end in ends]
    assert not [end for end in ends if end.end is not None and PROGRAM in end.end.why]
    assert not [note for note in notes if ALARM in note], notes
    assert client.traffic.errors == []
    assert len(client.traffic.latencies) > 100  # it polled all along
