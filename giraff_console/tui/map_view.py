"""The map view: the floor plan with the robot and its planned path, drawn in Braille.

The drawing is map_canvas's; this widget holds what to draw and where the operator is
looking. It follows the robot by default, but only re-centres when the robot nears an
edge, so that the map holds still while the robot crosses the middle rather than
scrolling under it every frame. Panning by hand stops the following; centring on the
robot starts it again.
"""

from __future__ import annotations

from dataclasses import replace

from rich.segment import Segment
from rich.style import Style
from textual import events
from textual.strip import Strip
from textual.widget import Widget

from giraff_console.tui.map_canvas import MapScene, Viewport, fit_grid, render_map

ZOOM_STEP = 1.25  # one notch of the mouse wheel
# The robot is re-centred once it leaves the middle 60% of the view.
FOLLOW_MARGIN = 0.2


class MapView(Widget):
    """Shows the latest MapScene; zoom, pan and follow the robot."""

    DEFAULT_CSS = """
    MapView { height: 1fr; }
    """

    def __init__(self, truecolor: bool = True, **kwargs) -> None:
        super().__init__(**kwargs)
        self.truecolor = truecolor
        self.scene: MapScene | None = None
        self.viewport: Viewport | None = None  # None until the first scene is fitted
        self.follow = True
        # Whether the view is the whole plan, as `fit` made it: kept whole when resized.
        self._fitted = False
        self._strips: list[Strip] | None = None
        self._drawn_for: tuple[Viewport, int, int] | None = None
        self._drag_from: tuple[float, float] | None = None  # the pointer, while dragging

    @property
    def caption(self) -> str:
        """One line for a border title, such as "map 0.2 m/dot · follow"."""
        if self.viewport is None:
            return "map"
        caption = f"map {self.viewport.metres_per_dot:.3g} m/dot"
        return f"{caption} · follow" if self.follow else caption

    def show(self, scene: MapScene) -> None:
        """Draw `scene` instead of the last one. Pass a new scene for every change: the
        drawing is kept until the scene, the viewport or the size changes."""
        self.scene = scene
        self._strips = None
        if self.viewport is None:
            self.fit()
        else:
            self._keep_robot_in_view()
            self._changed()

    def fit(self) -> None:
        """Show the whole plan; done for the first scene, and again once the size is known."""
        width, height = self.size
        if self.scene is not None and width and height:
            self.viewport = fit_grid(self.scene.walls, width, height)
            self._fitted = True
            self._keep_robot_in_view()
        self._changed()

    def zoom(self, factor: float, about: tuple[float, float] | None = None) -> None:
        """Closer by `factor` (> 1 zooms in), keeping the map point `about` in place."""
        if self.viewport is not None:
            self.viewport = self.viewport.zoomed(factor, about)
            self._fitted = False
            self._changed()

    def pan(self, dx_chars: float, dy_chars: float) -> None:
        """Move the view right and down by characters; the operator is looking somewhere
        else now, so the view stops following the robot."""
        if self.viewport is not None:
            self.viewport = self.viewport.panned(dx_chars, dy_chars)
            self.follow = self._fitted = False
            self._changed()

    def centre_on_robot(self) -> None:
        """Put the robot in the middle and follow it again."""
        self.follow = True
        robot = self.scene.robot if self.scene is not None else None
        if self.viewport is not None and robot is not None:
            self.viewport = replace(self.viewport, centre=(robot[0], robot[1]))
            self._fitted = False
        self._changed()

    def _keep_robot_in_view(self) -> None:
        """While following, re-centre once the robot leaves the middle of the view; not
        while the whole plan is in view and the robot on it, which is already the best
        view of both."""
        width, height = self.size
        if not self.follow or self.viewport is None or self.scene is None or not width:
            return
        robot = self.scene.robot
        if robot is None:
            return
        col, row = self.viewport.char_of(robot[0], robot[1], width, height)
        if (
            FOLLOW_MARGIN * width <= col + 0.5 <= (1 - FOLLOW_MARGIN) * width
            and FOLLOW_MARGIN * height <= row + 0.5 <= (1 - FOLLOW_MARGIN) * height
        ):
            return
        if 0 <= col < width and 0 <= row < height and self._whole_plan_in_view():
            return
        self.viewport = replace(self.viewport, centre=(robot[0], robot[1]))
        self._fitted = False

    def _whole_plan_in_view(self) -> bool:
        """Whether every cell of the grid is on screen."""
        assert self.scene is not None and self.viewport is not None
        grid, (width, height) = self.scene.walls, self.size
        rows, cols = grid.shape
        (left, bottom), half = grid.origin, grid.resolution / 2
        right, top = left + cols * grid.resolution, bottom + rows * grid.resolution
        corners = ((left + half, bottom + half), (right - half, top - half))
        for x, y in corners:
            col, row = self.viewport.char_of(x, y, width, height)
            if not (0 <= col < width and 0 <= row < height):
                return False
        return True

    def _changed(self) -> None:
        self.border_title = self.caption
        self.refresh()

    def on_resize(self) -> None:
        if self.viewport is None or self._fitted:
            self.fit()  # a scene shown before the widget had a size, or the whole plan
        else:
            self._keep_robot_in_view()
            self._changed()

    def on_mouse_scroll_up(self, event: events.MouseScrollUp) -> None:
        self._zoom_at(event, ZOOM_STEP)

    def on_mouse_scroll_down(self, event: events.MouseScrollDown) -> None:
        self._zoom_at(event, 1 / ZOOM_STEP)

    def _zoom_at(self, event: events.MouseEvent, factor: float) -> None:
        """Zoom about the point under the pointer, as map programs do."""
        event.stop()
        at = event.get_content_offset(self)
        if self.viewport is None or at is None:
            return
        width, height = self.size
        self.zoom(factor, self.viewport.point_at(at.x, at.y, width, height))

    def on_mouse_down(self, event: events.MouseDown) -> None:
        self._drag_from = (event.screen_x, event.screen_y)
        self.capture_mouse()

    def on_mouse_move(self, event: events.MouseMove) -> None:
        if self._drag_from is None:
            return
        (x, y), self._drag_from = self._drag_from, (event.screen_x, event.screen_y)
        if (x, y) != self._drag_from:
            # The map moves with the pointer, so the view moves the other way.
            self.pan(x - event.screen_x, y - event.screen_y)

    def on_mouse_up(self, event: events.MouseUp) -> None:
        self._drag_from = None
        self.release_mouse()

    def render_line(self, y: int) -> Strip:
        width, height = self.size
        if self.scene is None and y == height // 2:
            return Strip([Segment("no floor plan".center(width), Style(dim=True))]).crop(0, width)
        if self.scene is None or self.viewport is None:  # the latter until the size is known
            return Strip.blank(width)
        strips = self._drawing(width, height)
        return strips[y] if y < len(strips) else Strip.blank(width)

    def _drawing(self, width: int, height: int) -> list[Strip]:
        """The map as one strip a line, drawn again only when something changed."""
        assert self.scene is not None and self.viewport is not None
        drawn_for = (self.viewport, width, height)
        if self._strips is None or self._drawn_for != drawn_for:
            text = render_map(self.scene, self.viewport, width, height, self.truecolor)
            console = self.app.console
            self._strips = [
                Strip(line.render(console), width) for line in text.split("\n", allow_blank=True)
            ]
            self._drawn_for = drawn_for
        return self._strips
