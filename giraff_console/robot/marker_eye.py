"""The camera as the localisation's eye: its markers handed to the pose filter (issue 14).

With the console's screen, the camera feed already finds markers on its own thread
(camera/markers.py); `hand_on` is the listener that passes each frame's markers to the
control loop's localisation. Without a screen (`go`, `patrol`, with the simulator),
`MarkerEye` takes the frames itself at the camera's rate, on the loop's thread between
ticks of the simulator's stepped virtual clock, so that a frame falls at the same
virtual time whatever the speed and no virtual time passes while it is looked at. It
looks only where markers can be (robot/marker_search.py, issue 25): round those it
tracks and those the plan and the estimate put in view, with the whole frame searched
once a second and whenever the robot turns; a frame with nothing to look for is not
taken.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Protocol, runtime_checkable

import cv2
import numpy as np

from giraff_console.camera.defaults import EYE_FPS, EYE_SIZE
from giraff_console.camera.markers import MarkerDetector, MarkerSighting, Region
from giraff_console.camera.source import CameraSource, Frame
from giraff_console.clock import Clock
from giraff_console.robot.ekf import Observation
from giraff_console.robot.localisation import Localisation
from giraff_console.robot.marker_search import SEARCH_EVERY_S, Building, MarkerSearch


def observations(sightings: object) -> list[Observation]:
    """A frame's marker sightings (a processor's data under "markers") as the filter
    takes them; those without a distance (unknown intrinsics) are left to the filter
    to drop."""
    if not isinstance(sightings, list):
        return []
    return [
        Observation(s.id, s.distance_m, s.bearing_rad,
                    None if math.isnan(s.facing_rad) else s.facing_rad, s.frame_time)
        for s in sightings if isinstance(s, MarkerSighting)
    ]  # fmt: skip


def hand_on(localisation: Localisation) -> Callable[[Frame, dict[str, object]], None]:
    """A camera feed's listener that gives `localisation` each frame's markers."""

    def listener(frame: Frame, data: dict[str, object]) -> None:
        localisation.sighted(observations(data.get("markers")))

    return listener


@runtime_checkable
class RegionReadout(Protocol):
    """A camera that can read out only some regions of its frame, as many sensors can
    (a region of interest): the rest of the frame is then left unread."""

    def read_regions(self, regions: Sequence[Region]) -> Frame | None: ...


class MarkerEye:
    """Frames from `source` at `fps`, their markers found by `detector` and handed to
    `localisation`, when `look` is called; see the module docstring.

    `building`: what it knows of the building, to predict markers by (MarkerSearch).
    `whole_frames`: take every frame and look through all of it, as the eye did before
    issue 25 (what bench/sim_speed.py compares against)."""

    def __init__(self, source: CameraSource, detector: MarkerDetector,
                 localisation: Localisation, clock: Clock, *, fps: float = EYE_FPS,
                 size: tuple[int, int] = EYE_SIZE, building: Building | None = None,
                 whole_frames: bool = False) -> None:  # fmt: skip
        if not fps > 0:
            raise ValueError("the camera's rate must be positive")
        self.source = source
        self.detector = detector
        self.localisation = localisation
        self.clock = clock
        self.period = 1.0 / fps
        self.size = source.open(*size)
        every = max(1, round(SEARCH_EVERY_S * fps))  # frames
        search = None if whole_frames else MarkerSearch(localisation, detector, building, every)
        self.search = search
        self._readout = isinstance(source, RegionReadout)
        # What it has looked at, and what that cost in wall time: every frame taken
        # (rendered, with the simulator) and found markers in, and the finding alone;
        # the frames looked through whole, and those left untaken.
        self.frames = 0
        self.sightings = 0
        self.look_seconds = 0.0
        self.detect_seconds = 0.0
        self.whole = 0
        self.untaken = 0
        self._next = -math.inf

    def look(self) -> None:
        """Take a frame if one is due and there is anything to look for in it, find its
        markers and hand them on."""
        now = self.clock.now()
        if now < self._next:
            return
        self._next = max(self._next + self.period, now)
        started = time.perf_counter()
        regions = None if self.search is None else self.search.regions(*self.size)
        if regions == []:
            self.untaken += 1
            return
        if regions is not None and self._readout:
            frame = self.source.read_regions(regions)  # type: ignore[attr-defined]
        else:
            frame = self.source.read()
        if frame is None:
            return
        grey = grey_of(frame.image, regions)
        detecting = time.perf_counter()
        sightings = self.detector.detect(grey, frame.captured_at, regions)
        if self.search is not None:
            self.search.seen(sightings)
        found = observations(sightings)
        done = time.perf_counter()
        self.frames += 1
        self.whole += regions is None
        self.sightings += len(found)
        self.look_seconds += done - started
        self.detect_seconds += done - detecting
        self.localisation.sighted(found)

    def cost(self) -> dict[str, float | int | None]:
        """Frames and sightings so far, and the milliseconds a frame taken cost: all of
        it, and finding the markers alone; frames looked through whole, and not taken."""
        frames = self.frames
        return {
            "frames": frames,
            "sightings": self.sightings,
            "ms_per_frame": round(1e3 * self.look_seconds / frames, 2) if frames else None,
            "detect_ms_per_frame": round(1e3 * self.detect_seconds / frames, 2) if frames else None,
            "whole_frames": self.whole,
            "untaken_frames": self.untaken,
        }


def grey_of(image: np.ndarray, regions: list[Region] | None) -> np.ndarray:
    """The frame in grey: all of it, or only its `regions` (black elsewhere, where the
    detector will not look)."""
    if regions is None:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    grey = np.zeros(image.shape[:2], dtype=np.uint8)
    for r in regions:
        grey[r.top : r.bottom, r.left : r.right] = cv2.cvtColor(
            image[r.top : r.bottom, r.left : r.right], cv2.COLOR_BGR2GRAY
        )
    return grey
