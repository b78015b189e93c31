"""A loop stepped on a simulator's virtual clock keeps to real time at `--sim-speed 1`,
however often it is woken: a key or a job brings a tick forward, not the clock."""

from __future__ import annotations

import threading
import time

import pytest

from giraff_console.link import BoardLink
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.teleop import Teleop

pytestmark = pytest.mark.timeout(30)

WALL_S = 1.0
JOB_EVERY_S = 0.01  # a driver polling through the virtual port, and faster


def test_jobs_do_not_speed_up_the_virtual_clock():
    link = BoardLink.open("giraff-sim://?clock=virtual")
    clock = link.port.clock
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    control.start(stepped=1.0)
    try:
        time.sleep(0.2)  # connected
        virtual, wall = clock.now(), time.monotonic()
        jobs = 0
        while time.monotonic() - wall < WALL_S:
            done = threading.Event()
            control.submit(lambda link: None, lambda result, done=done: done.set())
            assert done.wait(5.0), "the loop did not run a job"
            jobs += 1
            time.sleep(JOB_EVERY_S)
        ratio = (clock.now() - virtual) / (time.monotonic() - wall)
    finally:
        assert control.stop()
    assert jobs > 40
    # Each early wake once moved the clock a whole tick on: 4 to 5 times real time here.
    # Below 1 when a busy machine keeps the loop from its ticks.
    assert 0.5 < ratio < 1.3, ratio
