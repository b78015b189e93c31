"""The route book's patrols: the operator's routes folder first, then the examples that
ship with the package (data_folders.example_routes), in the console and the daemon."""

from __future__ import annotations

from pathlib import Path

from giraff_console.data_folders import example_routes
from giraff_console.missions.drive_setup import DriveSetup
from giraff_console.missions.navigation import Navigator
from giraff_console.missions.patrol import PatrolRun
from giraff_console.missions.route_book import RouteBook
from giraff_console.missions.sessions import Sessions
from giraff_console.planning.route_planner import walls_of
from giraff_console.recording.session import RecordingSetup
from tests.missions.site import PLAN, Site


class Book:
    """The care home's simulated robot and a route book on an empty routes folder."""

    def __init__(self, folder: Path) -> None:
        navigator = Navigator(PLAN, walls_of(PLAN))
        self.site = Site(navigator)
        control = self.site.control
        self.routes = folder / "routes"
        self.routes.mkdir()
        self.said: list[str] = []
        sessions = Sessions(control, None, folder / "recordings", RecordingSetup(port="sim"),
                            self.said.append)  # fmt: skip
        drives = DriveSetup.on_loop(control, navigator, sense=self.site.sense)
        self.book = RouteBook(control, sessions, self.routes, self.said.append, drives,
                              examples=example_routes())  # fmt: skip

    def patrol(self) -> PatrolRun:
        self.site.run(0.2, until_ended=False)  # the loop takes the mission up
        mission = self.site.control.mission
        assert isinstance(mission, PatrolRun)
        return mission


def test_a_fresh_install_runs_the_example_night_patrol(tmp_path):
    book = Book(tmp_path)
    assert book.book.patrol("night")
    run = book.patrol()
    assert run.name == "night" and run.patrol.stops[0].room == "nurse-station"
    book.book.control.stop_mission()


def test_the_operators_own_patrol_of_the_same_name_comes_first(tmp_path):
    book = Book(tmp_path)
    (book.routes / "night.patrol.yaml").write_text(
        "rounds: 1\nsnapshots: false\nstops:\n  - {room: kitchen}\n"
    )
    assert book.book.patrol("night")
    assert [stop.room for stop in book.patrol().patrol.stops] == ["kitchen"]
    book.book.control.stop_mission()


def test_the_listing_names_the_examples_the_operators_patrols_do_not_hide(tmp_path):
    book = Book(tmp_path)
    assert book.book.listing() == [
        f"no routes in {book.routes}: `teach NAME` makes one",
        "example patrols: night",
    ]
    (book.routes / "night.patrol.yaml").write_text("rounds: 1\nstops:\n  - {room: kitchen}\n")
    assert book.book.listing() == ["routes: none", "patrols: night"]


def test_a_patrol_that_is_nowhere_is_refused_with_why(tmp_path):
    book = Book(tmp_path)
    assert not book.book.patrol("day")
    assert book.said and book.said[-1].startswith("no patrol day")
