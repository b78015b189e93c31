"""How `go` and `patrol` show a mission's progress on standard error."""

from __future__ import annotations

import io
import itertools
import sys

from giraff_console.cli.drive import PROGRESS_EVERY_S, ProgressShown
from giraff_console.robot.mission import DRIVING, Progress

LEG = Progress("go room-110", DRIVING, left_m=3.0, total_m=9.0, eta_s=7.0)
PATROL = Progress("patrol tour3", "round 3/3, stop 4/32 (room-110)", eta_s=20.0, detail=LEG)


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def clock(step: float):
    """A clock that moves on `step` seconds each time it is read: no test sleeps."""
    times = itertools.count(0.0, step)
    return lambda: next(times)


def test_off_a_terminal_the_progress_is_its_line_every_few_seconds_as_logs_read_it(capsys):
    shown = ProgressShown(clock(PROGRESS_EVERY_S / 2))
    for _ in range(4):
        shown.draw(PATROL)
    shown.close()
    err = capsys.readouterr().err
    assert err.splitlines() == ["patrol tour3: round 3/3, stop 4/32 (room-110), 20 s left"] * 2


def test_on_a_terminal_rich_draws_the_patrol_and_its_stop_and_leaves_piped_output_alone(
    capsys, monkeypatch
):
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    shown = ProgressShown(clock(1.0))
    for _ in range(3):
        shown.draw(PATROL)
        print('{"stop": 4}')
    shown.close()
    drawn = terminal.getvalue()
    assert "patrol tour3" in drawn and "round 3/3, stop 4/32 (room-110), 20 s left" in drawn
    assert "go room-110" in drawn and "3.0 m left, ETA 0:07" in drawn
    assert "━" in drawn and "█" not in drawn  # rich's bar, not the text one
    # Standard output piped (the JSON lines of --json): left where it goes.
    assert capsys.readouterr().out.splitlines() == ['{"stop": 4}'] * 3
    assert '{"stop": 4}' not in drawn
