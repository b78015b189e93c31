"""The control loop's thread asks to be run ahead of ordinary work (robot/realtime.py),
so that its ticks keep time on a busy PC (issue 15), and says so when it may not."""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
import threading

import pytest

from giraff_console.clock import RealClock
from giraff_console.link import BoardLink
from giraff_console.robot.control_loop import ControlLoop
from giraff_console.robot.deadman import Deadman
from giraff_console.robot.realtime import PRIORITY, run_promptly
from giraff_console.robot.teleop import Teleop

TIMEOUT_S = 20.0


def allowed() -> bool:
    """Whether this process may use real-time priority: root, or an rtprio limit."""
    return os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_RTPRIO)[0] >= 1


def test_a_thread_is_put_under_round_robin_where_the_process_may():
    said: list[str] = []
    policy: list[int] = []

    def thread() -> None:
        said.append(run_promptly(threading.get_native_id()))
        policy.append(os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK)

    worker = threading.Thread(target=thread)
    worker.start()
    worker.join(TIMEOUT_S)
    if allowed():
        assert said == [f"real-time priority {PRIORITY}"] and policy == [os.SCHED_RR]
    else:
        assert said[0].startswith("normal priority") and policy == [os.SCHED_OTHER]
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the caller's own thread is left


def test_a_user_without_an_rtprio_limit_is_told_why_and_runs_as_before():
    # In a child: no rtprio limit and, for root, another user, which has no CAP_SYS_NICE.
    child = """
import os, resource, threading
from giraff_console.robot.realtime import run_promptly
resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
if os.geteuid() == 0:
    os.setgid(65534)
    os.setuid(65534)
print(run_promptly(threading.get_native_id()))
print(os.sched_getscheduler(0) == os.SCHED_OTHER)
"""
    done = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=TIMEOUT_S, cwd="/")  # fmt: skip
    assert done.returncode == 0, done.stderr
    said, unchanged = done.stdout.splitlines()
    assert said.startswith("normal priority: this user may not use real-time priority")
    assert "rtprio" in said and unchanged == "True"


def test_the_loop_on_the_real_clock_asks_for_it():
    link = BoardLink.open("giraff-sim://")
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(RealClock()),
                          clock=RealClock())  # fmt: skip
    assert control.priority == "not running"
    control.start()
    try:
        thread = control._thread
        assert thread is not None and thread.native_id is not None
        policy = os.sched_getscheduler(thread.native_id) & ~os.SCHED_RESET_ON_FORK
        assert (policy == os.SCHED_RR) == allowed()
        assert control.priority.startswith("real-time" if allowed() else "normal priority")
        # What the loop's thread starts (a session's metadata, a patrol's snapshot)
        # does disk work at normal priority.
        started: list[int] = []

        def start_one() -> None:
            child = threading.Thread(target=lambda: started.append(os.sched_getscheduler(0)))
            child.start()
            child.join(TIMEOUT_S)

        done = threading.Event()
        control.between_ticks(lambda: (start_one(), done.set()))
        assert done.wait(TIMEOUT_S)
        assert started == [os.SCHED_OTHER]
    finally:
        assert control.stop()


@pytest.mark.parametrize(("speed", "asks"), [(1.0, True), (0.5, True), (4.0, False),
                                             (math.inf, False)])  # fmt: skip
def test_a_stepped_loop_asks_for_it_only_when_it_keeps_real_time(speed: float, asks: bool):
    """The daemon's simulator is stepped at real time: its loop is a robot's loop, on
    time beside busy work (issue 26); one stepped faster is a batch job."""
    link = BoardLink.open("giraff-sim://?clock=virtual")
    clock = link.port.clock
    control = ControlLoop(lambda: link, teleop=Teleop(), deadman=Deadman(clock), clock=clock)
    control.start(stepped=speed)
    try:
        thread = control._thread
        assert thread is not None and thread.native_id is not None
        policy = os.sched_getscheduler(thread.native_id) & ~os.SCHED_RESET_ON_FORK
        assert (policy == os.SCHED_RR) == (asks and allowed())
        if asks:
            assert control.priority.startswith("real-time" if allowed() else "normal priority")
        else:
            assert control.priority == "not running"
    finally:
        assert control.stop()
