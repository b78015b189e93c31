"""The map view: the Braille drawing of walls, doors, the robot and its path, and the
widget that zooms, pans and follows the robot."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rich.style import Style
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult

from giraff_console.planning.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from giraff_console.tui.map_canvas import (
    DOOR_CLOSED,
    DOOR_OPEN,
    MAX_METRES_PER_DOT,
    MIN_METRES_PER_DOT,
    PATH,
    ROBOT,
    UNSEEN,
    WALL,
    Viewport,
    fit_grid,
    layer_styles,
    render_map,
)
from giraff_console.tui.map_scene import DoorMark, MapScene, wall_direction
from giraff_console.tui.map_view import MapView

BLANK = chr(0x2800)


def free_grid(rows: int = 40, cols: int = 60, resolution: float = 0.1) -> OccupancyGrid:
    return OccupancyGrid(np.full((rows, cols), FREE, np.uint8), resolution)


def boxed_grid() -> OccupancyGrid:
    """A 6 m x 4 m room, walls one cell thick round its edge, unknown outside."""
    cells = np.full((50, 70), UNKNOWN, np.uint8)
    cells[5:45, 5:65] = OCCUPIED
    cells[6:44, 6:64] = FREE
    return OccupancyGrid(cells, 0.1, (-0.5, -0.5))


def lines(text: Text) -> list[str]:
    return text.plain.split("\n")


def style_at(text: Text, row: int, col: int) -> Style | None:
    offset = row * (len(lines(text)[0]) + 1) + col
    styles = [span.style for span in text.spans if span.start <= offset < span.end]
    return styles[-1] if styles else None


def char_at(text: Text, viewport: Viewport, x: float, y: float) -> tuple[str, Style | None]:
    """The character and style that show map point (x, y), found from the viewport alone."""
    rows, cols = len(lines(text)), len(lines(text)[0])
    left = viewport.centre[0] - cols * viewport.metres_per_dot
    top = viewport.centre[1] + 2 * rows * viewport.metres_per_dot
    col = math.floor((x - left) / (2 * viewport.metres_per_dot))
    row = math.floor((top - y) / (4 * viewport.metres_per_dot))
    return lines(text)[row][col], style_at(text, row, col)


def test_the_drawing_is_exactly_rows_lines_of_cols_braille_or_label_characters():
    scene = MapScene(
        boxed_grid(),
        labels=(("kitchen", (2.5, 1.5)),),
        robot=(1, 1, 0.3),
        path=((1, 1), (4, 3)),
        obstacles=((2, 2),),
    )
    for viewport in (
        fit_grid(scene.walls, 37, 11),
        Viewport((2.5, 1.5), 0.02),
        Viewport((500.0, -300.0), 2.0),
    ):
        drawn = lines(render_map(scene, viewport, 37, 11, truecolor=False))
        assert len(drawn) == 11
        assert all(len(line) == 37 for line in drawn)
        letters = {c for line in drawn for c in line if not 0x2800 <= ord(c) <= 0x28FF}
        assert letters <= set("kitchen")


def test_a_wall_cell_is_drawn_in_the_character_the_viewport_puts_it():
    grid = free_grid()
    grid.cells[15, 25] = OCCUPIED  # x 2.5..2.6, y 2.4..2.5
    viewport = Viewport((3.0, 2.0), 0.05)  # a cell is 2 x 2 dots
    text = render_map(MapScene(grid), viewport, 20, 10, truecolor=False)
    char, style = char_at(text, viewport, 2.55, 2.45)
    # The cell fills the lower two dot rows of a character whose left edge is x = 2.5.
    assert char == chr(0x2800 + 0x04 + 0x20 + 0x40 + 0x80)
    assert style == layer_styles(False)[WALL]
    assert sum(c != BLANK for line in lines(text) for c in line) == 1


def test_a_wall_one_cell_thin_survives_zooming_out_to_twenty_cells_a_dot():
    grid = free_grid(400, 400, 0.05)
    grid.cells[:, 201] = OCCUPIED  # a wall along x = 10.05..10.1
    viewport = Viewport((10.0, 10.0), 1.0)
    text = render_map(MapScene(grid), viewport, 20, 8, truecolor=False)
    wall_column = char_at(text, viewport, 10.07, 10.0)
    for y in (0.5, 4.5, 8.5, 12.5, 16.5, 19.5):  # in every character row over the grid
        assert char_at(text, viewport, 10.07, y)[0] != BLANK
    assert wall_column[1] == layer_styles(False)[WALL]


def test_an_open_door_is_green_and_a_closed_one_red():
    grid = free_grid()
    doors = (
        DoorMark("a", (1.5, 2.0), 0.8, True, (0.0, 1.0)),
        DoorMark("b", (4.5, 2.0), 0.8, False, (0.0, 1.0)),
    )
    viewport = fit_grid(grid, 30, 10)
    for truecolor in (False, True):
        text = render_map(MapScene(grid, doors=doors), viewport, 30, 10, truecolor)
        open_door, closed_door = (char_at(text, viewport, *door.centre) for door in doors)
        assert open_door[1] == layer_styles(truecolor)[DOOR_OPEN]
        assert closed_door[1] == layer_styles(truecolor)[DOOR_CLOSED]
        red, green = closed_door[1].color.get_truecolor(), open_door[1].color.get_truecolor()
        assert green.green > 2 * green.red and red.red > 2 * red.green


def test_the_wall_under_a_door_is_found_from_the_grid():
    grid = free_grid()
    grid.cells[:, 30] = OCCUPIED  # a wall along x = 3.0
    grid.cells[18:23, 30] = FREE  # a doorway 0.5 m wide at y = 2.0
    assert wall_direction(grid, (3.05, 2.0), 0.5) == pytest.approx((0.0, 1.0))


@pytest.mark.parametrize(
    ("heading", "ahead", "behind"),
    [(0.0, (0.5, 0.0), (-0.5, 0.0)), (math.pi / 2, (0.0, 0.5), (0.0, -0.5))],
)
def test_the_robot_is_bold_yellow_with_a_tick_where_it_heads(heading, ahead, behind):
    x, y = 3.025, 2.125  # the middle of a dot, so that no line falls between two
    viewport = Viewport((3.0, 2.0), 0.05)  # the disc is 12 dots across, the tick 12 long
    text = render_map(MapScene(free_grid(), robot=(x, y, heading)), viewport, 30, 10, False)
    robot = layer_styles(False)[ROBOT]
    assert robot.bold and "yellow" in robot.color.name
    assert char_at(text, viewport, x, y)[1] == robot
    assert char_at(text, viewport, x + ahead[0], y + ahead[1])[1] == robot
    assert char_at(text, viewport, x + behind[0], y + behind[1])[0] == BLANK


def test_the_robot_is_still_a_dot_zoomed_right_out():
    viewport = Viewport((3.0, 2.0), MAX_METRES_PER_DOT)
    text = render_map(MapScene(free_grid(), robot=(3.0, 2.0, 1.0)), viewport, 10, 4, False)
    char, style = char_at(text, viewport, 3.0, 2.0)
    assert char != BLANK and style == layer_styles(False)[ROBOT]


def test_the_path_is_drawn_cyan_and_connected():
    path = ((0.5, 0.5), (5.5, 0.5), (5.5, 3.5))
    viewport = fit_grid(free_grid(), 30, 10)
    text = render_map(MapScene(free_grid(), path=path), viewport, 30, 10, truecolor=False)
    assert "cyan" in layer_styles(False)[PATH].color.name
    along = [(x, 0.5) for x in np.arange(0.5, 5.5, 0.2)] + [(5.5, y) for y in np.arange(0.5, 3.5)]
    for x, y in along:
        assert char_at(text, viewport, x, y)[1] == layer_styles(False)[PATH]


def test_labels_show_when_they_fit_in_their_room_and_not_otherwise():
    scene = MapScene(boxed_grid(), labels=(("kitchen", (2.5, 1.5)), ("room-101", (2.5, 2.5))))
    close = render_map(scene, Viewport((2.5, 1.5), 0.05), 40, 12, truecolor=False).plain
    assert "kitchen" in close and "room-101" in close
    # At 0.125 m/dot the 6 m room is 24 characters: both still fit.
    middle = render_map(scene, fit_grid(scene.walls, 30, 10), 30, 10, truecolor=False).plain
    assert "kitchen" in middle and "room-101" in middle
    # At 0.5 m/dot it is 6 characters, 5 of them inside its walls: room-101 is cut to 101.
    far = render_map(scene, Viewport((2.5, 1.5), 0.5), 40, 12, truecolor=False).plain
    assert "kitchen" not in far and "room-101" not in far and "101" in far
    # At 1 m/dot nothing fits.
    further = render_map(scene, Viewport((2.5, 1.5), 1.0), 40, 12, truecolor=False).plain
    assert "101" not in further


def test_a_label_moves_a_line_to_keep_off_an_earlier_label_the_robot_and_the_path():
    labels = (("kitchen", (2.5, 1.5)), ("pantry", (2.6, 1.5)))
    viewport = Viewport((2.5, 1.5), 0.05)  # the labels' points are on line 6
    drawn = lines(render_map(MapScene(boxed_grid(), labels=labels), viewport, 40, 12, False))
    assert "kitchen" in drawn[6] and "pantry" in drawn[5]
    across = MapScene(boxed_grid(), labels=labels[:1], path=((0.5, 1.5), (5.5, 1.5)))
    assert "kitchen" in lines(render_map(across, viewport, 40, 12, False))[5]
    # A path up through the point blocks all three lines: the label covers it on its own.
    up = MapScene(boxed_grid(), labels=labels[:1], path=((2.5, 0.5), (2.5, 3.5)))
    assert "kitchen" in lines(render_map(up, viewport, 40, 12, False))[6]


def test_a_label_never_covers_the_robot():
    scene = MapScene(boxed_grid(), labels=(("kitchen", (2.5, 1.5)),), robot=(2.5, 1.5, 0.0))
    # Close up the robot covers lines 4 to 7, all the lines the label might take.
    assert "kitchen" not in render_map(scene, Viewport((2.5, 1.5), 0.05), 40, 12, False).plain
    # Fitted, it covers lines 5 and 6: the label goes below it.
    drawn = lines(render_map(scene, fit_grid(scene.walls, 30, 10), 30, 10, False))
    assert [i for i, line in enumerate(drawn) if "kitchen" in line] == [7]


def test_zoom_clamps_and_keeps_the_point_it_zooms_about_in_place():
    viewport = Viewport((0.0, 0.0), 0.1)
    assert viewport.zoomed(1000).metres_per_dot == MIN_METRES_PER_DOT
    assert viewport.zoomed(1 / 1000).metres_per_dot == MAX_METRES_PER_DOT
    closer = viewport.zoomed(2, about=(3.0, 1.0))
    assert closer.metres_per_dot == pytest.approx(0.05)

    def on_screen(view: Viewport) -> tuple[float, float]:  # (3, 1) in characters
        left, top = view.corner(40, 10)
        return (3.0 - left) / (2 * view.metres_per_dot), (top - 1.0) / (4 * view.metres_per_dot)

    assert on_screen(closer) == pytest.approx(on_screen(viewport))
    assert viewport.panned(5, 2).centre == pytest.approx((1.0, -0.8))


def test_fit_shows_the_whole_grid_filling_the_tighter_side():
    grid = boxed_grid()  # 7 m x 5 m, the room's walls 0.5 m in from its edges
    viewport = fit_grid(grid, 30, 10)  # 60 x 40 dots: the height is the tighter
    assert viewport.metres_per_dot == pytest.approx(5.0 / 40)
    assert viewport.char_of(-0.49, -0.49, 30, 10) == (1, 9)
    assert viewport.char_of(6.49, 4.49, 30, 10) == (28, 0)
    text = render_map(MapScene(grid), viewport, 30, 10, truecolor=False)
    walls = [
        (row, col)
        for row in range(10)
        for col in range(30)
        if style_at(text, row, col) == layer_styles(False)[WALL]
    ]
    assert {row for row, _ in walls} == set(range(1, 9))  # 0.5 m is one row in from each edge
    assert {col for _, col in walls} == set(range(3, 27))


def test_unknown_space_is_a_sparse_stipple_that_keeps_out_of_wall_characters():
    grid = boxed_grid()
    viewport = fit_grid(grid, 30, 10)
    text = render_map(MapScene(grid), viewport, 30, 10, truecolor=False)
    known = OccupancyGrid(np.where(grid.cells == UNKNOWN, FREE, grid.cells), 0.1, grid.origin)
    without = render_map(MapScene(known), viewport, 30, 10, truecolor=False)
    unseen = layer_styles(False)[UNSEEN]
    stippled = [(r, c) for r in range(10) for c in range(30) if style_at(text, r, c) == unseen]
    assert len(stippled) >= 20  # the 0.5 m margin round the room
    assert all(bin(ord(lines(text)[r][c]) - 0x2800).count("1") == 1 for r, c in stippled)
    assert lines(without) == [
        "".join(BLANK if (r, c) in stippled else ch for c, ch in enumerate(line))
        for r, line in enumerate(lines(text))
    ]
    off_grid = render_map(MapScene(grid), Viewport((500.0, -300.0), 2.0), 30, 10, False)
    assert set(off_grid.plain) == {BLANK, "\n"}


class MapApp(App):
    def compose(self) -> ComposeResult:
        yield MapView()


def drawn(view: MapView) -> str:
    return "\n".join(view.render_line(y).text for y in range(view.size.height))


async def test_the_view_hints_without_a_plan_then_draws_zooms_pans_and_follows():
    app = MapApp()
    async with app.run_test(size=(40, 12)) as pilot:
        view = app.query_one(MapView)
        assert "no floor plan" in drawn(view)
        scene = MapScene(boxed_grid(), robot=(1.0, 1.0, 0.0))
        view.show(scene)
        await pilot.pause()
        assert "no floor plan" not in drawn(view)
        assert {"⢸", "⡇"} & set(drawn(view))  # the room's side walls
        assert view.viewport == fit_grid(scene.walls, 40, 12)  # the robot is on the plan
        assert view.caption == "map 0.104 m/dot · follow"

        view.zoom(4)  # 2 m x 1.25 m in view now
        assert view.viewport.metres_per_dot == pytest.approx(5 / 48 / 4)
        view.show(MapScene(scene.walls, robot=(3.1, 2.0, 0.0)))  # near the middle: stays
        assert view.viewport.centre == pytest.approx(fit_grid(scene.walls, 40, 12).centre)
        view.show(MapScene(scene.walls, robot=(3.7, 2.0, 0.0)))  # near the edge: re-centred
        assert view.viewport.centre == (3.7, 2.0)

        view.pan(4, 0)
        assert view.viewport.centre[0] > 3.7 and not view.follow
        assert view.caption.endswith("m/dot")
        view.centre_on_robot()
        assert view.viewport.centre == (3.7, 2.0) and view.follow


async def test_scrolling_zooms_about_the_pointer():
    app = MapApp()
    async with app.run_test(size=(40, 12)) as pilot:
        view = app.query_one(MapView)
        view.show(MapScene(boxed_grid()))
        await pilot.pause()
        before = view.viewport
        under = before.point_at(10, 3, 40, 12)
        view.post_message(events.MouseScrollUp(view, 10, 3, 0, 0, 0, False, False, False))
        await pilot.pause()
        assert view.viewport.metres_per_dot < before.metres_per_dot
        assert view.viewport.char_of(*under, 40, 12) == (10, 3)
        view.post_message(events.MouseScrollDown(view, 10, 3, 0, 0, 0, False, False, False))
        await pilot.pause()
        assert view.viewport.metres_per_dot == pytest.approx(before.metres_per_dot)


async def test_dragging_moves_the_map_with_the_pointer():
    app = MapApp()
    async with app.run_test(size=(40, 12)) as pilot:
        view = app.query_one(MapView)
        view.show(MapScene(boxed_grid()))
        await pilot.pause()
        grabbed = view.viewport.point_at(10, 3, 40, 12)
        await pilot.mouse_down(MapView, offset=(10, 3))
        await pilot.hover(MapView, offset=(12, 4))
        await pilot.hover(MapView, offset=(14, 5))
        await pilot.mouse_up(MapView, offset=(14, 5))
        assert view.viewport.char_of(*grabbed, 40, 12) == (14, 5)
        assert not view.follow
