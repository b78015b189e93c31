"""An idle screen repaints nothing (issue 26): the map is not drawn again for a snapshot
that would look the same to the dot, and the top line and the main view are not
updated with the text they already show. Counted, not timed."""

from __future__ import annotations

from dataclasses import replace

from textual.app import App, ComposeResult

from giraff_console.robot.odometry import Pose
from giraff_console.robot.telemetry import LinkState, Telemetry
from giraff_console.tui.main_view import MainView
from giraff_console.tui.map_canvas import Viewport, drawing_key, render_map
from giraff_console.tui.map_scene import MapScene, located
from giraff_console.tui.map_view import MapView
from giraff_console.tui.top_bar import TopBar
from tests.tui.test_map_canvas import free_grid
from tests.tui.test_map_estimate import estimate_at

VIEW = Viewport((3.0, 2.0), 0.05)
HERE = Pose(3.0, 2.0, 0.3)
ELLIPSE = (0.2, 0.1, 0.4)


def corrected(scene: MapScene, by: float) -> MapScene:
    """`scene` with the robot and its ellipse as a marker's correction leaves them: the
    pose a few micrometres off, the ellipse a hair smaller."""
    pose = Pose(HERE.x + by, HERE.y - by, HERE.heading + by)
    ellipse = (ELLIPSE[0] - by, ELLIPSE[1] - by, ELLIPSE[2])
    return located(scene, pose, estimate_at(pose, ellipse))


def test_a_correction_of_micrometres_is_drawn_alike_and_keyed_alike():
    scene = MapScene(free_grid())
    still = corrected(scene, 0.0)
    for by in (1e-6, 3e-6, -2e-6):
        moved = corrected(scene, by)
        assert moved != still
        assert drawing_key(moved, VIEW, 40, 12) == drawing_key(still, VIEW, 40, 12)
        assert render_map(moved, VIEW, 40, 12, True) == render_map(still, VIEW, 40, 12, True)


def test_what_shows_on_the_map_makes_a_new_key():
    scene = MapScene(free_grid())
    still = drawing_key(corrected(scene, 0.0), VIEW, 40, 12)
    a_dot_on = located(scene, Pose(HERE.x + 0.05, HERE.y, HERE.heading), None)
    assert drawing_key(a_dot_on, VIEW, 40, 12) != drawing_key(located(scene, HERE, None), VIEW,
                                                               40, 12)  # fmt: skip
    wider = located(scene, HERE, estimate_at(HERE, (0.4, 0.1, 0.4)))
    assert drawing_key(wider, VIEW, 40, 12) != still
    seen = replace(corrected(scene, 0.0), seen=(3,))
    assert drawing_key(seen, VIEW, 40, 12) != still
    assert drawing_key(corrected(scene, 0.0), VIEW, 40, 13) != still
    assert drawing_key(corrected(scene, 0.0), Viewport((3.0, 2.0), 0.04), 40, 12) != still


class MapApp(App[None]):
    def compose(self) -> ComposeResult:
        yield MapView(id="map")


async def test_the_map_is_not_drawn_or_repainted_for_snapshots_that_look_the_same():
    app = MapApp()
    async with app.run_test(size=(40, 12)) as pilot:
        view = app.query_one(MapView)
        scene = MapScene(free_grid())
        view.show(corrected(scene, 0.0))
        await pilot.pause()
        assert view.drawings == 1
        repaints = []
        view.refresh = lambda *args, **kwargs: repaints.append(1)  # type: ignore[method-assign]
        for tick in range(20):  # a second of snapshots, each corrected a little
            view.show(corrected(scene, 1e-6 * (tick % 3)))
            view.show(corrected(scene, 1e-6 * (tick % 3)))  # and the same one again
            await pilot.pause()
        assert view.drawings == 1 and repaints == []
        moved = Pose(HERE.x + 0.1, HERE.y, HERE.heading)  # two dots on
        view.show(located(scene, moved, estimate_at(moved, ELLIPSE)))
        assert repaints == [1]
        del view.refresh
        view.refresh()
        await pilot.pause()
        assert view.drawings == 2


def telemetry(x: float = 0.0, loop_hz: float = 20.0) -> Telemetry:
    return Telemetry(LinkState.CONNECTED, None, Pose(x, 0.0, 0.0), None, 0.3, None, True,
                     loop_hz, 0.0)  # fmt: skip


class Lines(App[None]):
    def compose(self) -> ComposeResult:
        yield TopBar(simulator=True, id="top")
        yield MainView(id="main")


async def test_the_top_line_and_the_main_view_are_not_updated_with_what_they_show():
    app = Lines()
    async with app.run_test(size=(100, 5)) as pilot:
        top, main = app.query_one(TopBar), app.query_one(MainView)
        for _ in range(20):
            top.show(telemetry())
            main.show(telemetry())
            await pilot.pause()
        assert top.updates == 1 and main.updates == 2  # once each: its line, and two lines
        top.show(telemetry(loop_hz=19.0))  # the loop's rate dips: the line says so
        assert top.updates == 2
        top.show(telemetry(x=1.0))
        assert top.updates == 3 and "X=1.00" in str(top.render())
        main.show(replace(telemetry(), speed=0.35))  # the keys' speed: the second line
        assert main.updates == 3
