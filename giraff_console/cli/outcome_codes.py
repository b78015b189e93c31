"""How each outcome of a mission ends the command that drove it: its exit code
(exit_codes.py's numbers, which `--help` and the README say in words)."""

from __future__ import annotations

from giraff_console.cli.exit_codes import (
    EXIT_ARRIVED,
    EXIT_BOARD,
    EXIT_FAILED,
    EXIT_NOT_STARTED,
    EXIT_STOPPED,
    EXIT_UNVERIFIED,
)
from giraff_console.robot.mission import MissionEnd, Outcome

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


def exit_code(end: MissionEnd) -> int:
    return EXIT_CODES[end.outcome]
