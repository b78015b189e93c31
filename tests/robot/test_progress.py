"""A mission's progress as data, and the one line it reads as where there is only text."""

from __future__ import annotations

from giraff_console.robot.mission import ARRIVED, DRIVING, PAUSED, TEXT_BAR, Progress


def test_a_path_under_way_reads_as_its_bar_metres_left_and_eta():
    progress = Progress("go day-room", DRIVING, left_m=35.4, total_m=42.8, eta_s=91.2)
    assert progress.line() == "go day-room ███░░░░░░░░░░░░░ 35.4 m left, ETA 1:31"
    assert progress.done_m == 42.8 - 35.4


def test_a_path_whose_metres_left_are_not_known_shows_an_empty_bar_and_no_eta():
    progress = Progress("go kitchen", "stopping to plan a new way (a door closed)", total_m=20.0)
    assert progress.done_m == 0.0
    assert progress.line() == (
        f"go kitchen {'░' * TEXT_BAR} stopping to plan a new way (a door closed), no ETA"
    )


def test_what_a_mission_is_doing_comes_before_its_figures():
    paused = Progress("go kitchen", PAUSED, left_m=12.34, total_m=12.34)
    assert paused.line() == f"go kitchen {'░' * TEXT_BAR} paused, 12.3 m left"
    backing = Progress("undock", "backing out (paused)", left_m=0.3)
    assert backing.line() == "undock: backing out (paused), 0.3 m left"
    assert Progress("go kitchen", ARRIVED).line() == "go kitchen: arrived"


def test_more_metres_left_than_the_plan_fill_none_of_the_bar():
    progress = Progress("go kitchen", "no nearer for 12 s", left_m=21.0, total_m=20.0)
    assert progress.done_m == 0.0
    assert progress.line() == f"go kitchen {'░' * TEXT_BAR} no nearer for 12 s, 21.0 m left"


def test_without_metres_the_time_left_is_counted_in_minutes_and_seconds():
    stop = "round 3/3, stop 4/32 (room-110)"
    assert Progress("patrol tour3", stop, eta_s=7.2).line() == (
        "patrol tour3: round 3/3, stop 4/32 (room-110), 7 s left"
    )
    assert Progress("patrol tour3", stop, eta_s=65).words() == f"{stop}, 1 min 05 s left"
    assert Progress("patrol tour3", stop).done_m is None


def test_a_progress_with_figures_keeps_its_detail_out_of_its_line():
    leg = Progress("go room-110", DRIVING, left_m=3.1, total_m=9.0, eta_s=7.0)
    patrol = Progress("patrol tour3", "round 3/3, stop 4/32 (room-110)", eta_s=20.0, detail=leg)
    assert patrol.line() == "patrol tour3: round 3/3, stop 4/32 (room-110), 20 s left"


def test_a_progress_without_figures_goes_on_with_its_details_line():
    charging = Progress("charging at the dock", "40 % of 90 %")
    patrol = Progress("patrol night", "round 1/2, before stop 1 (kitchen)", detail=charging)
    assert patrol.line() == (
        "patrol night: round 1/2, before stop 1 (kitchen): charging at the dock: 40 % of 90 %"
    )
    assert Progress("going to the dock", "").line() == "going to the dock"


def test_brief_words_put_what_is_left_first_in_fewer_characters():
    """For a narrow screen (the main view at 80x24): the end of a line is what it cuts."""
    leg = Progress("go room-105", DRIVING, left_m=14.7, total_m=20.0, eta_s=40.0)
    assert leg.words(brief=True) == "14.7 m, ETA 0:40"
    patrol = Progress("patrol night", "round 1/1, stop 2/6 (room-105)", eta_s=302.0,
                      detail=leg, brief="stop 2/6")  # fmt: skip
    assert patrol.words(brief=True) == "5:02 left, stop 2/6"
    assert patrol.words() == "round 1/1, stop 2/6 (room-105), 5 min 02 s left"
    # Without a brief state, the state itself, after the figures.
    paused = Progress("go kitchen", PAUSED, left_m=12.34, total_m=12.34)
    assert paused.words(brief=True) == "12.3 m, paused"
    # The line where there is only text is as it has always been.
    assert patrol.line() == "patrol night: round 1/1, stop 2/6 (room-105), 5 min 02 s left"
