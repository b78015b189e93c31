"""The `giraff-console` program's entry point: signals are blocked before any thread starts.

numpy's and OpenCV's thread pools start as they are imported, with the signal mask of
the thread that imports them. A SIGHUP landing on one of those threads would end the
process at once, leaving the robot on its last target; blocked on every thread, the
console's own watcher takes it instead and stops the robot first (robot/last_stop.py).
Commands that drive nothing unblock them again straight away (cli/main.py).

Those pools are OpenBLAS's: numpy's and OpenCV's own copy each start a worker that
busy-waits as it loads, about 0.09 s of CPU each, paid by every command that loads them
(issue 26, item 6: a fifth of the console's first screen). The robot's matrices (the
filter's, a survey's marker covariances, 750 across for 250 markers) are too small for a
second thread to pay for itself, so BLAS runs on the calling thread unless the
environment asks for more.

Everything the robot writes is its owner's alone (issue 30, private_files.py): the umask
is set to 0o077 before anything else, once, so that every file and folder the program
makes is private whoever makes it: our writers (which give the modes themselves too),
OpenCV's VideoWriter, NumPy, the YAML and image writers, temporary files. It only
narrows: a folder the operator made keeps its mode.
"""

from __future__ import annotations

import os
import signal
import sys

# private_files.PRIVATE_UMASK, held equal by tests/test_private_files.py: that module
# loads pathlib and typing, which `stop` (below) has no use for.
UMASK = 0o077


def main() -> int:
    os.umask(UMASK)
    if sys.argv[1:2] == ["stop"]:
        # The operator's stop, in a hurry: its own module alone, no signals blocked (it
        # starts no thread), nothing else of the package loaded (cli/stop.py).
        from giraff_console.cli.stop import main as stop

        return stop(sys.argv[2:])
    # Read by each OpenBLAS as it loads, so before anything imports numpy or OpenCV.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from giraff_console.robot.last_stop import SIGNALS

    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    # Imported only now, so that no thread can start before the mask is in place.
    from giraff_console.cli.main import main as run

    return run()
