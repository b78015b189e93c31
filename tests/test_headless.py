"""How `go` and `patrol` show a mission's progress on standard error."""

from __future__ import annotations

import io
import sys

from giraff_console.headless import _show_progress
from giraff_console.robot.mission import DRIVING, Progress

LEG = Progress("go room-110", DRIVING, left_m=3.0, total_m=9.0, eta_s=7.0)
PATROL = Progress("patrol tour3", "round 3/3, stop 4/32 (room-110)", eta_s=20.0, detail=LEG)


class Patrolling:
    """A mission that only reports its progress."""

    name = "tour3"
    progress = PATROL


class Done:
    """Done after `waits` waits, each at once: no test sleeps."""

    def __init__(self, waits: int) -> None:
        self.waits = waits

    def wait(self, timeout: float) -> bool:
        self.waits -= 1
        return self.waits < 0


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_off_a_terminal_the_progress_is_its_line_as_logs_read_it(capsys):
    said: list[str] = []
    _show_progress(Patrolling(), Done(2), lambda: said.append("meanwhile"))
    err = capsys.readouterr().err
    assert err.splitlines() == ["patrol tour3: round 3/3, stop 4/32 (room-110), 20 s left"] * 2
    assert said == ["meanwhile"] * 3  # after each line, and once at the end


def test_on_a_terminal_rich_draws_the_patrol_and_its_stop_and_leaves_piped_output_alone(
    capsys, monkeypatch
):
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    _show_progress(Patrolling(), Done(2), lambda: print('{"stop": 4}'))
    drawn = terminal.getvalue()
    assert "patrol tour3" in drawn and "round 3/3, stop 4/32 (room-110), 20 s left" in drawn
    assert "go room-110" in drawn and "3.0 m left, ETA 0:07" in drawn
    assert "━" in drawn and "█" not in drawn  # rich's bar, not the text one
    # Standard output piped (the JSON lines of --json): left where it goes.
    assert capsys.readouterr().out.splitlines() == ['{"stop": 4}'] * 3
    assert '{"stop": 4}' not in drawn
