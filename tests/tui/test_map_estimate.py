"""The map shows how well the robot knows where it is: its uncertainty ellipse, and the
plan's markers, those seen lately and those the filter's gate rejected (issue 14)."""

from __future__ import annotations

import math

import numpy as np
from textual.app import App, ComposeResult

from giraff_console.planning.floorplan import load_floorplan
from giraff_console.planning.grid import FREE, OCCUPIED, OccupancyGrid
from giraff_console.planning.route_planner import walls_of
from giraff_console.robot.localisation import Estimate
from giraff_console.robot.odometry import Pose
from giraff_console.tui import map_view
from giraff_console.tui.map_canvas import (
    DOOR_CLOSED,
    ELLIPSE,
    MARKER,
    MARKER_REJECTED,
    MARKER_SEEN,
    ROBOT,
    WALL,
    Viewport,
    layer_styles,
    render_map,
)
from giraff_console.tui.map_scene import DoorMark, MapScene, MarkerMark, located, plan_scene
from giraff_console.tui.map_view import MapView
from tests.tui.conftest import EXAMPLE
from tests.tui.test_map_canvas import char_at, free_grid

STYLES = layer_styles(False)
SIGMA = "\N{GREEK SMALL LETTER SIGMA}"


def estimate_at(pose: Pose, ellipse: tuple[float, float, float], **kwargs) -> Estimate:
    major, minor, _ = ellipse
    covariance = ((major**2, 0.0, 0.0), (0.0, minor**2, 0.0), (0.0, 0.0, 1e-4))
    return Estimate(pose, pose, covariance, major, 0.01, ellipse, landmarks=True, **kwargs)


def test_the_ellipse_is_drawn_at_two_sigma_along_its_angle_round_the_robot():
    x, y = 3.025, 2.125  # the middle of a dot
    viewport = Viewport((3.0, 2.0), 0.05)
    for angle, major_axis in ((0.0, (1.0, 0.0)), (math.pi / 2, (0.0, 1.0))):
        scene = MapScene(free_grid(), robot=(x, y, 0.0), robot_radius=0.1,
                         ellipse=(0.5, 0.2, angle))  # fmt: skip
        text = render_map(scene, viewport, 40, 12, truecolor=False)
        (ux, uy), (vx, vy) = major_axis, (-major_axis[1], major_axis[0])
        for reach in (1.0, -1.0):  # the two-sigma ends of the major axis
            assert char_at(text, viewport, x + reach * ux, y + reach * uy)[1] == STYLES[ELLIPSE]
        for reach in (0.4, -0.4):  # and of the minor one
            assert char_at(text, viewport, x + reach * vx, y + reach * vy)[1] == STYLES[ELLIPSE]
        # One sigma out along the major axis is inside the outline: nothing there.
        assert char_at(text, viewport, x + 0.5 * ux, y + 0.5 * uy)[1] is None
        assert char_at(text, viewport, x, y)[1] == STYLES[ROBOT]


def test_an_ellipse_smaller_than_the_robot_is_hidden_under_it():
    scene = MapScene(free_grid(), robot=(3.0, 2.0, 0.0), ellipse=(0.05, 0.05, 0.0))
    text = render_map(scene, Viewport((3.0, 2.0), 0.05), 40, 12, truecolor=False)
    assert all(span.style != STYLES[ELLIPSE] for span in text.spans)


def test_markers_show_on_their_wall_in_three_styles_seen_rejected_and_not():
    grid = free_grid()
    grid.cells[:, 30] = OCCUPIED  # a wall along x = 3.0 .. 3.1
    markers = (
        MarkerMark(1, (3.0, 0.5), math.pi),  # on the wall's left face, looking left
        MarkerMark(2, (3.0, 2.0), math.pi),
        MarkerMark(3, (3.1, 3.5), 0.0),  # on its right face
    )
    scene = MapScene(grid, markers=markers, seen=(2, 3), rejected=(3,))
    viewport = Viewport((3.0, 2.0), 0.1)  # the wall is a dot thick, a marker three
    text = render_map(scene, viewport, 40, 12, truecolor=False)
    assert char_at(text, viewport, 2.95, 0.5)[1] == STYLES[MARKER]
    assert char_at(text, viewport, 2.95, 2.0)[1] == STYLES[MARKER_SEEN]
    assert char_at(text, viewport, 3.15, 3.5)[1] == STYLES[MARKER_REJECTED]  # rejected wins
    assert len({STYLES[MARKER], STYLES[MARKER_SEEN], STYLES[MARKER_REJECTED], STYLES[WALL]}) == 4
    # Between the markers the wall is a wall.
    assert char_at(text, viewport, 3.05, 1.25)[1] == STYLES[WALL]


def test_markers_back_to_back_on_a_wall_stay_apart_close_up():
    grid = OccupancyGrid(np.full((40, 60), FREE, np.uint8), 0.1)
    grid.cells[:, 30] = OCCUPIED
    markers = (MarkerMark(1, (3.0, 2.0), math.pi), MarkerMark(2, (3.1, 2.0), 0.0))
    viewport = Viewport((3.05, 2.0), 0.02)
    text = render_map(MapScene(grid, markers=markers, seen=(2,)), viewport, 40, 12, False)
    assert char_at(text, viewport, 2.92, 2.0)[1] == STYLES[MARKER]
    assert char_at(text, viewport, 3.18, 2.0)[1] == STYLES[MARKER_SEEN]


def test_a_shut_door_beside_a_marker_still_shows_red_zoomed_out():
    grid = free_grid()
    grid.cells[:, 30] = OCCUPIED
    door = DoorMark("d", (3.05, 2.0), 0.8, False, (0.0, 1.0))
    marker = MarkerMark(1, (3.0, 2.5), math.pi)  # beside the doorway, as `landmarks` puts it
    viewport = Viewport((3.2, 2.6), 0.4)  # a character is 0.8 m x 1.6 m
    assert viewport.char_of(*door.centre, 20, 6) == viewport.char_of(2.92, 2.5, 20, 6)
    text = render_map(MapScene(grid, doors=(door,), markers=(marker,)), viewport, 20, 6, False)
    assert char_at(text, viewport, *door.centre)[1] == STYLES[DOOR_CLOSED]


def test_the_example_plans_markers_are_on_its_map():
    plan = load_floorplan(EXAMPLE)
    grid = walls_of(plan)
    assert plan.landmarks is not None and grid is not None
    scene = plan_scene(plan, grid)
    assert len(scene.markers) == len(plan.landmarks.markers) == 176
    first = plan.landmarks.markers[0]
    assert scene.markers[0] == MarkerMark(first.id, first.at, math.radians(first.facing))


def test_located_takes_the_ellipse_and_the_markers_from_the_estimate_or_clears_them():
    scene = MapScene(free_grid())
    pose = Pose(1.0, 2.0, 0.5)
    shown = located(scene, pose, estimate_at(pose, (0.3, 0.1, 0.5), seen=(4, 7), rejected=(9,)))
    assert shown.robot == (1.0, 2.0, 0.5) and shown.ellipse == (0.3, 0.1, 0.5)
    assert shown.seen == (4, 7) and shown.rejected == (9,)
    played = located(shown, Pose(2.0, 2.0, 0.0), None)
    assert played.ellipse is None and played.seen == played.rejected == ()
    # A filter not placed yet has no ellipse to draw.
    unplaced = located(scene, pose, estimate_at(pose, (math.inf, math.inf, 0.0)))
    assert unplaced.ellipse is None


class MapApp(App):
    def compose(self) -> ComposeResult:
        yield MapView(id="map")


async def test_the_view_draws_again_only_when_the_scene_changes(monkeypatch):
    drawings = []
    real = map_view.render_map

    def counted(*args, **kwargs):
        drawings.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(map_view, "render_map", counted)
    app = MapApp()
    async with app.run_test(size=(40, 12)) as pilot:
        view = app.query_one(MapView)
        scene = located(MapScene(free_grid()), Pose(3.0, 2.0, 0.0), None)
        view.show(scene)
        await pilot.pause()
        assert len(drawings) == 1
        for _ in range(3):  # the robot standing still: a new, equal scene every tick
            view.show(located(scene, Pose(3.0, 2.0, 0.0), None))
            await pilot.pause()
        assert len(drawings) == 1
        view.show(located(scene, Pose(3.0, 2.0, 0.0), estimate_at(Pose(3, 2), (0.4, 0.2, 0))))
        await pilot.pause()
        assert len(drawings) == 2 and drawings[-1].ellipse == (0.4, 0.2, 0)


async def test_the_caption_says_the_ellipse_is_two_sigma_and_names_the_marker_colours():
    app = MapApp()
    async with app.run_test(size=(80, 12)) as pilot:
        view = app.query_one(MapView)
        view.show(MapScene(free_grid()))
        await pilot.pause()
        assert view.caption == "map 0.0833 m/dot · follow"
        markers = (MarkerMark(1, (1.0, 1.0), 0.0),)
        view.show(MapScene(free_grid(), robot=(3, 2, 0), ellipse=(0.3, 0.1, 0), markers=markers))
        await pilot.pause()
        assert view.caption == f"map 0.0833 m/dot · follow · 2{SIGMA} · markers seen rejected"
        assert f"ellipse round it is 2{SIGMA}" in str(view.tooltip)
        assert "inside it 86% of the time" in str(view.tooltip)
