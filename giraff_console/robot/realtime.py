"""Asking the kernel to run the control loop's thread before ordinary work.

The loop must tick every 50 ms, on time, however busy the robot's PC is (issue 15: p99
lateness ≤ 5 ms beside two busy processes). Ordinary threads share the CPUs fairly, so
on a loaded machine a loop that wakes on time can still wait several milliseconds for
a CPU. Under a real-time policy (SCHED_RR) it is run as soon as it wakes, ahead of
every ordinary thread, as robot control loops usually are (ros2_control does the same
for its update thread). The console in its own process asks for it too, on a real
board. The loop sleeps between ticks, and the kernel's real-time throttling (by default
950 ms of each second, per CPU on most kernels) bounds what a stuck loop could take.
Threads the loop starts are not given it (SCHED_RESET_ON_FORK).

Only a process allowed to may do it: root, CAP_SYS_NICE, or a user given an `rtprio`
limit (docs/daemon.md, "Ticks on time"). Without that the loop runs as before, and says
why once.
"""

from __future__ import annotations

import os

# Low among real-time priorities (1-99): ahead of ordinary threads, behind the kernel's
# own and anything an administrator has placed higher.
PRIORITY = 10


def run_promptly(thread: int) -> str:
    """Put `thread` (a native thread id) under SCHED_RR at PRIORITY, if this process
    may; what became of it, for the operator ("real-time priority 10", or why not)."""
    try:
        limit = os.sched_get_priority_max(os.SCHED_RR)
        priority = min(PRIORITY, limit)
        # Reset on fork: the threads the loop starts (a session's metadata, a patrol's
        # snapshot) do disk work that must not run ahead of everything else.
        policy = os.SCHED_RR | os.SCHED_RESET_ON_FORK
        os.sched_setscheduler(thread, policy, os.sched_param(priority))
    except PermissionError:
        return ("normal priority: this user may not use real-time priority (an rtprio "
                "limit allows it, docs/daemon.md)")  # fmt: skip
    except (AttributeError, OSError) as error:  # not Linux, or a kernel that refuses
        return f"normal priority: {error}"
    return f"real-time priority {priority}"
