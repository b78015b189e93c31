"""The `giraff-console` program's entry point: signals are blocked before any thread starts.

numpy's and OpenCV's thread pools start as they are imported, with the signal mask of
the thread that imports them. A SIGHUP landing on one of those threads would end the
process at once, leaving the robot on its last target; blocked on every thread, the
console's own watcher takes it instead and stops the robot first (robot/last_stop.py).
Commands that drive nothing unblock them again straight away (cli.py).
"""

from __future__ import annotations

import signal

from giraff_console.robot.last_stop import SIGNALS


def main() -> int:
    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    # Imported only now, so that no thread can start before the mask is in place.
    from giraff_console.cli import main as run

    return run()
