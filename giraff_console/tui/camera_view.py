"""The main view: the camera, drawn from lines the camera feed rendered off the UI thread."""

from __future__ import annotations

from rich.segment import Segment
from rich.style import Style
from textual.strip import Strip
from textual.widget import Widget

from giraff_console.camera.feed import CameraPicture


class CameraView(Widget):
    """Shows the latest camera picture; tells the feed how big it is."""

    DEFAULT_CSS = """
    CameraView { height: 1fr; }
    """

    def __init__(self, **kwargs) -> None:
        super().__init__(**kwargs)
        self.picture: CameraPicture | None = None
        self.on_size = lambda columns, rows: None

    def show(self, picture: CameraPicture) -> None:
        """Draw `picture`; not again if it has the lines on screen already (only what the
        top line says of it changed)."""
        same = self.picture is not None and picture.lines is self.picture.lines
        self.picture = picture
        if not same:
            self.refresh()

    def on_resize(self) -> None:
        self.on_size(self.size.width, self.size.height)

    def render_line(self, y: int) -> Strip:
        width = self.size.width
        if self.picture is None:
            if y == self.size.height // 2:
                return Strip([Segment("no camera picture".center(width), Style(dim=True))])
            return Strip.blank(width)
        if y >= len(self.picture.lines):
            return Strip.blank(width)
        return Strip(self.picture.lines[y]).adjust_cell_length(width).crop(0, width)
