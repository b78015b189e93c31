"""The main view's second line: the keys, or a mission's progress drawn with a bar; and the
top line's BLOCKED badge."""

from __future__ import annotations

from dataclasses import replace

import pytest
from textual.app import App, ComposeResult
from textual.widgets import Label, ProgressBar, Static

from giraff_console.robot.mission import DRIVING, TEXT_BAR, Progress
from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.tui.main_view import MainView
from giraff_console.tui.top_bar import TopBar


class OneView(App[None]):
    def compose(self) -> ComposeResult:
        yield MainView(id="main")


def telemetry(mission: Progress | None) -> Telemetry:
    return Telemetry(LinkState.CONNECTED, None, Pose(0.0, 0.0, 0.0), None, 0.3, None, True,
                     20.0, 0.0, mission=mission)  # fmt: skip


def shown(view: MainView) -> list[str]:
    return [str(label.content) for label in view.query(Label) if label.display]


def bars(view: MainView) -> list[tuple[float | None, float]]:
    return [(bar.total, bar.progress) for bar in view.query(ProgressBar) if bar.display]


def keys(view: MainView) -> Static:
    return view.query_children(Static)[1]


async def test_a_mission_takes_the_keys_place_its_bar_measuring_the_plan_under_way():
    app = OneView()
    async with app.run_test(size=(100, 4)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(None))
        await pilot.pause()
        assert keys(view).display and "keys - 0.30 m/s" in str(keys(view).content)
        view.show(telemetry(Progress("go kitchen", DRIVING, 5.0, 20.0, 12.0)))
        await pilot.pause()
        assert not keys(view).display
        assert shown(view) == ["go kitchen", "5.0 m left, ETA 0:12"]
        assert bars(view) == [(20.0, 15.0)]
        view.show(telemetry(None))  # ended
        await pilot.pause()
        assert keys(view).display


async def test_a_patrol_shows_its_round_and_its_stop_with_the_stops_bar():
    leg = Progress("go room-110", DRIVING, left_m=3.0, total_m=9.0, eta_s=7.0)
    patrol = Progress("patrol tour3", "round 3/3, stop 4/32 (room-110)", eta_s=20.0, detail=leg)
    app = OneView()
    async with app.run_test(size=(120, 4)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(patrol))
        await pilot.pause()
        assert shown(view) == [
            "patrol tour3:", "round 3/3, stop 4/32 (room-110), 20 s left",
            "· go room-110", "3.0 m left, ETA 0:07",
        ]  # fmt: skip
        assert bars(view) == [(9.0, 6.0)]


async def test_in_a_narrow_view_the_bar_gives_way_to_the_metres_and_the_eta():
    """At 80x24 the main view is some 36 columns: the bar shrinks so that what is left
    and the ETA stay on the line; wide, it is its full length."""
    for width, bar_width in ((36, range(1, 8)), (100, range(TEXT_BAR, TEXT_BAR + 1))):
        app = OneView()
        async with app.run_test(size=(width, 4)) as pilot:
            view = app.query_one(MainView)
            view.show(telemetry(Progress("go kitchen", DRIVING, 45.0, 47.0, 120.0)))
            await pilot.pause()
            words = [label for label in view.query(Label) if label.display][-1]
            assert str(words.content) == "45.0 m left, ETA 2:00"
            assert words.region.right <= width
            (bar,) = [bar for bar in view.query(ProgressBar) if bar.display]
            assert bar.region.width in bar_width


async def test_held_keys_that_do_not_move_the_robot_show_blocked():
    class OneBar(App[None]):
        def compose(self) -> ComposeResult:
            yield TopBar(simulator=False)

    app = OneBar()
    async with app.run_test(size=(100, 2)) as pilot:
        bar = app.query_one(TopBar)
        bar.show(telemetry(None))
        await pilot.pause()
        assert "BLOCKED" not in str(bar.render())
        bar.show(replace(telemetry(None), blocked=True))
        await pilot.pause()
        assert str(bar.render()).startswith(" BLOCKED ")


def patrol_on_its_way(room: str = "room-105", left_m: float = 14.7) -> Progress:
    leg = Progress(f"go {room}", DRIVING, left_m=left_m, total_m=20.0, eta_s=40.0)
    return Progress("patrol night", f"round 1/1, stop 2/6 ({room})", eta_s=80.0, detail=leg,
                    brief="stop 2/6")  # fmt: skip


def labels_within(view: MainView, width: int) -> bool:
    return all(label.region.right <= width for label in view.query(Label) if label.display)


async def test_at_80x24_a_patrol_and_its_legs_eta_stay_on_screen():
    """The main view at 80x24 is 36 columns (34 inside): one line cannot hold the patrol
    and its leg, so the leg goes on a line of its own, the patrol's words brief (its time
    left first, the room left to the leg's name); the leg keeps its metres and ETA."""
    app = OneView()
    async with app.run_test(size=(36, 5)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(patrol_on_its_way()))
        await pilot.pause()
        assert shown(view) == ["patrol night:", "1:20 left, stop 2/6", "go room-105",
                               "14.7 m left, ETA 0:40"]  # fmt: skip
        assert view.size.height == 3 and labels_within(view, 36)
        # A longer room's name: the leg's words brief too, and no room for its bar.
        view.show(telemetry(patrol_on_its_way("activity-room")))
        await pilot.pause()
        assert shown(view)[2:] == ["go activity-room", "14.7 m, ETA 0:40"]
        assert labels_within(view, 36) and bars(view) == []


async def test_a_patrol_that_fits_on_one_line_stays_there():
    app = OneView()
    async with app.run_test(size=(120, 5)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(patrol_on_its_way()))
        await pilot.pause()
        assert shown(view) == ["patrol night:", "round 1/1, stop 2/6 (room-105), 1 min 20 s left",
                               "· go room-105", "14.7 m left, ETA 0:40"]  # fmt: skip
        assert view.size.height == 2 and bars(view) == [(20.0, pytest.approx(5.3))]


async def test_narrowed_the_view_lays_the_patrol_out_again_and_widened_too():
    app = OneView()
    async with app.run_test(size=(120, 5)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(patrol_on_its_way()))
        await pilot.pause()
        await pilot.resize_terminal(36, 5)
        await pilot.pause()
        assert view.size.height == 3 and labels_within(view, 36)
        await pilot.resize_terminal(120, 5)
        await pilot.pause()
        assert view.size.height == 2 and len(shown(view)) == 4


async def test_a_dwelling_patrol_says_its_time_left_first_when_narrow():
    dwelling = Progress("patrol night", "round 1/1, stop 2/6 (room-105)", eta_s=80.0,
                        brief="stop 2/6")  # fmt: skip
    app = OneView()
    async with app.run_test(size=(36, 5)) as pilot:
        view = app.query_one(MainView)
        view.show(telemetry(dwelling))
        await pilot.pause()
        assert shown(view) == ["patrol night:", "1:20 left, stop 2/6"]
        assert view.size.height == 2 and labels_within(view, 36)
