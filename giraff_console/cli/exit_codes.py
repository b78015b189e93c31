"""How a command that drives ends: an exit code for each outcome of its mission, and the
words `--help` gives them. Apart from drive.py, which follows the mission, so that
`--help` can say them without loading the robot (issue 26, item 6).
"""

from __future__ import annotations

from giraff_console.robot.mission import MissionEnd, Outcome

EXIT_ARRIVED = 0  # also: a patrol whose every stop was reached, confirmed
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_UNVERIFIED = 3
EXIT_STOPPED = 4
EXIT_BOARD = 5
EXIT_NOT_STARTED = 6
# How each outcome ends the command.
EXIT_CODES: dict[Outcome, int] = {
    Outcome.ARRIVED: EXIT_ARRIVED,
    Outcome.DONE: EXIT_ARRIVED,
    Outcome.ARRIVED_UNVERIFIED: EXIT_UNVERIFIED,
    Outcome.STALLED: EXIT_FAILED,
    Outcome.BLOCKED: EXIT_FAILED,
    Outcome.LOST: EXIT_FAILED,
    Outcome.FAILED: EXIT_FAILED,
    Outcome.REFUSED: EXIT_FAILED,
    Outcome.STOPPED_BY_OPERATOR: EXIT_STOPPED,
    Outcome.CANCELLED: EXIT_STOPPED,
    Outcome.HALTED: EXIT_STOPPED,
    Outcome.ESTOP: EXIT_BOARD,
    Outcome.LINK_LOST: EXIT_BOARD,
    Outcome.NOT_STARTED: EXIT_NOT_STARTED,
    Outcome.UNVERIFIED: EXIT_NOT_STARTED,
}
EXIT_HELP = (
    "Exit codes: 0 arrived with the pose confirmed by a marker (a patrol: every stop); "
    "1 did not get there (stalled, blocked, lost, failed, a command refused; a patrol: a "
    "stop missed), or no answer from the board; 2 a mistake in the command; 3 arrived, "
    "but nothing confirmed the pose; 4 stopped by the operator, a signal or another "
    "mission; 5 the board's ESTOP, or the link to it lost; 6 not started (the pose "
    "cannot be trusted, or a playback runs)."
)


def exit_code(end: MissionEnd) -> int:
    return EXIT_CODES[end.outcome]
