"""The map view: the floor plan with the robot, how well it knows where it is, the
markers it finds itself by and its planned path, drawn in Braille.

The drawing is map_canvas's; this widget holds what to draw and where the operator is
looking. It follows the robot by default, but only re-centres when the robot nears an
edge, so that the map holds still while the robot crosses the middle rather than
scrolling under it every frame. Panning by hand stops the following; centring on the
robot starts it again.
"""

from __future__ import annotations

import math
from dataclasses import replace

from rich.segment import Segment
from rich.style import Style
from rich.text import Text
from textual import events
from textual.strip import Strip
from textual.widget import Widget

from giraff_console.service.vocabulary import RECENT_S
from giraff_console.tui.map_canvas import (
    ELLIPSE,
    ELLIPSE_SIGMAS,
    MARKER,
    MARKER_REJECTED,
    MARKER_SEEN,
    Viewport,
    drawing_key,
    fit_grid,
    layer_styles,
    render_map,
)
from giraff_console.tui.map_scene import MapScene

ZOOM_STEP = 1.25  # one notch of the mouse wheel
# The robot is re-centred once it leaves the middle 60% of the view.
FOLLOW_MARGIN = 0.2
_SIGMAS = f"{ELLIPSE_SIGMAS:g}\N{GREEK SMALL LETTER SIGMA}"
# The chance that a two-dimensional normal falls within k sigmas: 1 - exp(-k²/2).
_INSIDE = 1 - math.exp(-(ELLIPSE_SIGMAS**2) / 2)
# The legend in full; the caption's is short enough for the map beside the logs.
LEGEND = (
    f"The robot is yellow, and the gold ellipse round it is {_SIGMAS}: the robot is inside "
    f"it {_INSIDE:.0%} of the time. Markers are purple, magenta if seen in the last "
    f"{RECENT_S:g} s, orange if rejected as not where the plan says. Wheel to zoom, drag "
    "to pan."
)


class MapView(Widget):
    """Shows the latest MapScene; zoom, pan and follow the robot."""

    DEFAULT_CSS = """
    MapView { height: 1fr; }
    """

    def __init__(self, truecolor: bool = True, **kwargs) -> None:
        super().__init__(**kwargs)
        self.truecolor = truecolor
        self.tooltip = LEGEND
        self.scene: MapScene | None = None
        self.viewport: Viewport | None = None  # None until the first scene is fitted
        self.follow = True
        # Whether the view is the whole plan, as `fit` made it: kept whole when resized.
        self._fitted = False
        self._strips: list[Strip] | None = None
        # What the strips were drawn from (map_canvas.drawing_key), and how many times
        # the map has been drawn: a scene that would be drawn alike is not drawn again.
        self._drawn_for: tuple[object, ...] | None = None
        self.drawings = 0
        self._caption_shown: Text | None = None
        self._drag_from: tuple[float, float] | None = None  # the pointer, while dragging

    @property
    def caption(self) -> str:
        """One line for a border title, such as "map 0.2 m/dot · follow"."""
        return self._title().plain

    def _title(self) -> Text:
        """The caption, with a legend in the map's colours for what needs one: the
        ellipse, how many sigmas it is drawn at, and the markers' three states."""
        if self.viewport is None:
            return Text("map")
        title = Text(f"map {self.viewport.metres_per_dot:.3g} m/dot")
        if self.follow:
            title.append(" · follow")
        scene, styles = self.scene, layer_styles(self.truecolor)
        if scene is not None and scene.ellipse is not None:
            title.append(" · ").append(_SIGMAS, styles[ELLIPSE])
        if scene is not None and scene.markers:
            title.append(" · ").append("markers", styles[MARKER]).append(" ")
            title.append("seen", styles[MARKER_SEEN]).append(" ")
            title.append("rejected", styles[MARKER_REJECTED])
        return title

    def show(self, scene: MapScene) -> None:
        """Draw `scene` instead of the last one. Pass a new scene for every change: the
        drawing is kept until what it shows, the viewport or the size changes. A scene
        equal to the last one, or one that would be drawn alike to the dot (the
        estimate's corrections while the robot stands still), is not drawn again, and
        the screen is not asked to repaint the map (issue 26)."""
        if scene == self.scene:
            return
        self.scene = scene
        if self.viewport is None:
            self.fit()
        else:
            self._keep_robot_in_view()
            self._changed()

    def regrid(self, scene: MapScene) -> None:
        """Draw `scene`, whose grid is another (a map growing, or a new plan): the
        whole of it, if the whole of the last was in view."""
        self.show(scene)
        if self._fitted:
            self.fit()

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
        """Repaint, if what the map or its caption shows has changed."""
        title = self._title()
        if title != self._caption_shown:
            self.border_title = self._caption_shown = title
        if self._drawn_for is None or self._drawn_for != self._key(*self.size):
            self.refresh()

    def _key(self, width: int, height: int) -> tuple[object, ...] | None:
        """What a drawing of the scene at this size would be drawn from; None before
        there is anything to draw."""
        if self.scene is None or self.viewport is None:
            return None
        return drawing_key(self.scene, self.viewport, width, height)

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
        drawn_for = self._key(width, height)
        if self._strips is None or self._drawn_for != drawn_for:
            text = render_map(self.scene, self.viewport, width, height, self.truecolor)
            console = self.app.console
            self._strips = [
                Strip(line.render(console), width) for line in text.split("\n", allow_blank=True)
            ]
            self._drawn_for = drawn_for
            self.drawings += 1
        return self._strips
