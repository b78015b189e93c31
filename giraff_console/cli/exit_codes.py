"""How a command ends: the exit codes, and the words `--help` gives those of a command
that drives. Plain numbers, so that `--help`, and `giraff-console stop` in a hurry
(stop.py), say and use them without loading the robot (issue 26, item 6; issue 30);
which outcome of a mission gives which is outcome_codes.py's.
"""

from __future__ import annotations

EXIT_ARRIVED = 0  # also: a patrol whose every stop was reached, confirmed
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_UNVERIFIED = 3
EXIT_STOPPED = 4
EXIT_BOARD = 5
EXIT_NOT_STARTED = 6
# `status`, `stop`, `patrols` and `watch`: done, or no daemon to ask.
EXIT_DONE, EXIT_NO_DAEMON = 0, 3
EXIT_HELP = (
    "Exit codes: 0 arrived with the pose confirmed by a marker (a patrol: every stop); "
    "1 did not get there (stalled, blocked, lost, failed, a command refused; a patrol: a "
    "stop missed), or no answer from the board; 2 a mistake in the command; 3 arrived, "
    "but nothing confirmed the pose; 4 stopped by the operator, a signal or another "
    "mission; 5 the board's ESTOP, or the link to it lost; 6 not started (the pose "
    "cannot be trusted, or a playback runs)."
)
