"""The camera feed: capture, processing and terminal rendering, off the UI thread.

Frames are taken at up to a capped rate (10 fps by default, about what the Giraff's
camera delivers at 800x600, §3.3), run through the enabled processors, and rendered as
half blocks for the pane's current size; the UI only draws the finished lines.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from rich.segment import Segment

from giraff_console.camera.defaults import DEFAULT_FPS
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.processors import Pipeline
from giraff_console.camera.source import CameraSource, Frame


@dataclass(frozen=True)
class CameraPicture:
    """One rendered frame and what the top line says about it (the thesis's SetCameraInfo)."""

    lines: list[list[Segment]]
    source: str
    size: tuple[int, int]
    fps: float
    keypoints: int | None
    # The ids of the markers found in the frame, when the marker detector ran on it.
    markers: tuple[int, ...] | None = None


class CameraFeed:
    """Runs the camera in its own thread; `publish` gets each picture."""

    def __init__(self, source: CameraSource, size: tuple[int, int], pipeline: Pipeline,
                 renderer: HalfBlockRenderer, publish: Callable[[CameraPicture], None],
                 fps_cap: float = DEFAULT_FPS) -> None:  # fmt: skip
        self.source = source
        self.size = size
        self.pipeline = pipeline
        self.renderer = renderer
        self.publish = publish
        self.period = 1.0 / fps_cap
        # What the status log says about the camera, fallbacks included.
        self.note = f"{source.name} at {size[0]}x{size[1]}"
        self._cells = (80, 20)
        self._wanted: tuple[int, int] | None = None
        self._next_source: CameraSource | None = None
        # Called with every raw frame, on the camera's thread: a recording, a snapshot.
        self.taps: list[Callable[[Frame], None]] = []
        # Called with every frame and what the processors found in it, on the camera's
        # thread: marker sightings for localisation ("markers" in the data).
        self.listeners: list[Callable[[Frame, dict[str, object]], None]] = []
        self.last_frame: Frame | None = None
        # Whether the picture is on screen: hidden, it is neither drawn nor published,
        # and no frame is taken at all unless a tap or a listener wants it (issue 15: the
        # half-block drawing is the camera's largest cost on the robot's small PC).
        self.shown = True
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera", daemon=True)
        self._times: list[float] = []

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2)
        self.source.close()

    def set_cells(self, columns: int, rows: int) -> None:
        """The pane's size in character cells."""
        self._cells = (max(1, columns), max(1, rows))

    def set_resolution(self, width: int, height: int) -> None:
        """Ask the camera for another resolution, from the next frame on (keys 1-5)."""
        self._wanted = (width, height)

    def switch(self, source: CameraSource) -> CameraSource:
        """Show `source` from the next frame on; returns the one shown until now, which is
        closed then and can be switched back to (playback shows a recording, then the
        camera again)."""
        previous = self._next_source or self.source
        self._next_source = source
        return previous

    @property
    def wanted(self) -> bool:
        """Whether anything needs frames now: the screen, a recording, the localisation."""
        return self.shown or bool(self.taps) or bool(self.listeners)

    def picture(self) -> CameraPicture | None:
        """Capture, process and render one frame; None if the camera gave none, or if the
        picture is not shown (the frame still goes to the taps and listeners)."""
        if self._next_source is not None:
            self.source.close()
            self.source, self._next_source = self._next_source, None
            self._wanted = self._wanted or self.size
        if self._wanted is not None:
            wanted, self._wanted = self._wanted, None
            self.source.close()
            self.size = self.source.open(*wanted)
        frame = self.source.read()
        if frame is None:
            return None
        self.last_frame = frame
        for tap in list(self.taps):
            tap(frame)
        processed = self.pipeline.run(frame.image, frame.captured_at)
        for listener in list(self.listeners):
            listener(frame, processed.data)
        now = time.monotonic()
        self._times = [t for t in self._times if now - t < 1.0] + [now]
        if not self.shown:
            return None
        keypoints = processed.data.get("keypoints")
        markers = processed.data.get("marker_ids")
        return CameraPicture(
            self.renderer.render(processed.image, *self._cells),
            self.source.name,
            frame.size,
            float(len(self._times)),
            keypoints if isinstance(keypoints, int) else None,
            tuple(markers) if isinstance(markers, list) else None,
        )

    def _run(self) -> None:
        next_frame = time.monotonic()
        while not self._stop.is_set():
            picture = self.picture() if self.wanted else None
            if picture is not None:
                self.publish(picture)
            # Keep to the cap on average: the next frame is due a period after the last
            # one was due, not a period after this one finished.
            next_frame = max(next_frame + self.period, time.monotonic() - self.period)
            self._stop.wait(max(0.0, next_frame - time.monotonic()))
