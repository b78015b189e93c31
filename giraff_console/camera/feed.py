"""The camera feed: capture, processing and terminal rendering, off the UI thread.

Frames are taken at up to a capped rate (10 fps by default, about what the Giraff's
camera delivers at 800x600, §3.3), run through the enabled processors, and rendered as
half blocks for the pane's current size; the UI only draws the finished lines.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from rich.segment import Segment

from giraff_console.camera.defaults import DEFAULT_FPS
from giraff_console.camera.halfblock import HalfBlockRenderer
from giraff_console.camera.processors import Pipeline
from giraff_console.camera.source import CameraSource, Frame

# Who takes each frame for consoles elsewhere: the processed image, the rate, the FAST
# corners and the markers found.
Share = Callable[[np.ndarray, float, int | None, tuple[int, ...] | None], None]


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
        # The picture last handed on to be shown, with the image it was made from and the
        # processors and pane it was made for; the ids of the markers last found (None
        # while no marker detector runs); how many pictures have been rendered.
        self._shown_picture: tuple[np.ndarray, tuple[object, ...], CameraPicture] | None = None
        self._markers: tuple[int, ...] | None = None
        self.renders = 0
        # Called with every frame for consoles in other processes, processed (its
        # overlays drawn) but not rendered, while any of them shows the camera
        # (camera/shared_frame.py): the image, the rate, the FAST corners and markers.
        # The same image drawn again is handed on as the same object, so that whoever
        # encodes it can tell it need not.
        self.share: Share | None = None
        self._shared: tuple[np.ndarray, tuple[str, ...], np.ndarray, int | None] | None = None

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
        """Whether anything needs frames now: the screen, a console elsewhere, a
        recording, the localisation."""
        return self.shown or self.share is not None or bool(self.taps) or bool(self.listeners)

    @property
    def rate(self) -> float:
        """Frames taken in the last second."""
        now = time.monotonic()
        return float(sum(now - taken < 1.0 for taken in self._times))

    def picture(self) -> CameraPicture | None:
        """Capture, process and render one frame; None if the camera gave none, if the
        picture is not shown (the frame still goes to the taps and listeners), or if it
        would show what is on screen already."""
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
        now = time.monotonic()
        self._times = [t for t in self._times if now - t < 1.0] + [now]
        fps = float(len(self._times))
        # The same image again (a simulated robot standing still, sim/pose_view.py)
        # through the same processors into the same pane is the picture on screen: it
        # is neither processed for the screen nor drawn again (issue 26).
        enabled = tuple(self.pipeline.enabled)
        drawn_for = (enabled, self._cells)
        last = self._shown_picture
        again = last is not None and last[0] is frame.image and last[1] == drawn_for
        share, shared = self.share, self._shared
        shared_again = shared is not None and shared[0] is frame.image and shared[1] == enabled
        draw = (self.shown and not again) or (share is not None and not shared_again)
        processed = self.pipeline.run(frame.image, frame.captured_at, draw)
        for listener in list(self.listeners):
            listener(frame, processed.data)
        markers = processed.data.get("marker_ids")
        if isinstance(markers, list):
            # Kept until the detector next runs: it may run on fewer frames than shown.
            self._markers = tuple(markers)
        found = processed.data.get("keypoints")
        keypoints = found if isinstance(found, int) else None
        if share is None:
            self._shared = None
        else:
            if not shared_again:
                shared = self._shared = (frame.image, enabled, processed.image, keypoints)
            assert shared is not None
            share(shared[2], fps, shared[3], self._markers)
        if not self.shown:
            self._shown_picture = None  # shown again, the next frame is drawn
            return None
        if last is not None and again:
            picture = last[2]
            if picture.fps == fps and picture.markers == self._markers:
                return None
            # Only the top line's words have changed: the picture's lines are the same.
            picture = replace(picture, fps=fps, markers=self._markers)
        else:
            picture = CameraPicture(
                self.renderer.render(processed.image, *self._cells),
                self.source.name,
                frame.size,
                fps,
                keypoints,
                self._markers,
            )
            self.renders += 1
        self._shown_picture = (frame.image, drawn_for, picture)
        return picture

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
