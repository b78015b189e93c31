"""What `giraff-console patrol` prints (cli/patrol.py): a line for each stop as the
service reports it, and the patrol's last line at its end, in words or as JSON. The same
lines whether the patrol runs on the robot in this process or on the daemon's: the
service reports both the same way (missions/patrol_report.py, issue 26). Apart from the
parser, so that `--help` does not load the robot's types (issue 26, item 6).
"""

from __future__ import annotations

import json

from giraff_console.cli.drive import Ended
from giraff_console.cli.exit_codes import EXIT_FAILED
from giraff_console.cli.outcome_codes import EXIT_CODES, exit_code
from giraff_console.cli.report import fail
from giraff_console.missions.patrol_report import PATROL_JSON_KEYS, PatrolReport
from giraff_console.service.events import PatrolStopReported, Reply, ServiceEvent


class PatrolLines:
    """The lines of patrol `name` (the patrol's own name, its file's: drive.mission_name)
    on standard output: each stop's as it is heard, on the thread that follows the
    patrol, then the patrol's."""

    def __init__(self, name: str, as_json: bool) -> None:
        self.name = name
        self.as_json = as_json

    def heard(self, event: ServiceEvent) -> None:
        """Every event the service says while the patrol runs: its stops are printed."""
        if isinstance(event, PatrolStopReported) and event.report.patrol == self.name:
            data = event.report.as_json()
            print(json.dumps(data) if self.as_json else stop_words(data), flush=True)

    def ended(self, ended: Ended | Reply | None, gone: str) -> int:
        """The patrol's last line; its exit code. `gone`: what to say if the robot (the
        board, or the daemon) went before the patrol ended."""
        if ended is None:
            return fail(gone, EXIT_FAILED)
        if isinstance(ended, Reply):
            # Refused before it started (the note on standard error says why).
            return fail(ended.text, EXIT_CODES[ended.refused] if ended.refused else EXIT_FAILED)
        end, report = ended.end, ended.report
        if isinstance(report, PatrolReport):
            data = report.as_json()
            words = (f"patrol {self.name}: {data['why']}; {data['arrived']} of {data['stops']} "
                     f"stops arrived, in {data['duration_s']:.0f} s")  # fmt: skip
        else:
            # The end came, but not the report (drive.follow): the end, with the same keys.
            data = dict.fromkeys(PATROL_JSON_KEYS) | {
                "patrol": self.name, "outcome": end.outcome.value, "why": end.why,
                "detail": end.detail,
            }  # fmt: skip
            words = f"patrol {self.name}: {end.words}"
        print(json.dumps(data) if self.as_json else words, flush=True)
        return exit_code(end)


def stop_words(data: dict) -> str:
    """A stop's line in words, from its JSON (StopReport.as_json)."""
    place = data["room"] or data["route"]
    how = data["detail"] or data["why"]
    where = ""
    if data["error_m"] is not None:
        where = (f"; {data['error_m'] * 100:.1f} cm and {data['heading_error_deg']:.1f}° "
                 "from its goal")  # fmt: skip
    return (f"round {data['round']}, stop {data['stop']} ({place}): {how}{where}; "
            f"known to {data['sigma_m'] * 100:.1f} cm")  # fmt: skip
